//! Validation of a scene's `output` object: the quantity each model can report, the orders listed, the
//! sample rate, duration, noise, speed modulation, tachometer channels and WAV format of a written signal.

use super::raw::RawOutput;
use super::validate::Validator;
use super::{OutputOptions, SceneError, SpeedChange, WavFormat};
use crate::model::{GearPair, MeshStiffness, OutputQuantity, PressParams, SecondOrderSystem};
use crate::system::PeriodicSystem;
use std::f64::consts::PI;

impl Validator<'_> {
    pub(super) fn common_output(
        &self,
        o: &RawOutput,
        quantity: OutputQuantity,
        base_hz: f64,
        base_name: &str,
        default_max_order: f64,
        default_fs: f64,
    ) -> Result<OutputOptions, SceneError> {
        let max_order = match o.max_order {
            Some(m) => self.positive("output.max_order", m)?,
            None => default_max_order,
        };
        if max_order > 1e6 {
            return Err(self.err("output.max_order", format!("must be at most 1e6, got {max_order}")));
        }
        let fs = match o.sample_rate_hz {
            Some(fs) => self.positive("output.sample_rate_hz", fs)?,
            None => default_fs,
        };
        if fs > 10e6 {
            return Err(self.err("output.sample_rate_hz", format!("must be at most 10 MHz, got {fs}")));
        }
        let duration_s = match o.duration_s {
            Some(d) => self.positive("output.duration_s", d)?,
            None => 1.0,
        };
        let speed_change = self.speed_change(o, duration_s)?;
        let wav_format = o.wav_format.unwrap_or(WavFormat::F32);
        let full_scale = match o.full_scale {
            // a reader scales integer samples in [-1, 1] by it into 32-bit floats
            Some(x) if x > f64::from(f32::MAX) => {
                return Err(self.err("output.full_scale", format!("{x:e} is beyond 32-bit float range (3.4e38)")));
            }
            Some(x) => Some(self.positive("output.full_scale", x)?),
            None => None,
        };
        Ok(OutputOptions {
            quantity,
            base_hz,
            base_name: base_name.to_string(),
            max_order,
            sample_rate_hz: fs,
            duration_s,
            noise_rms: self.non_negative("output.noise_rms", o.noise_rms.unwrap_or(0.0))?,
            seed: o.seed.unwrap_or(1),
            speed_change,
            tacho: o.tacho.unwrap_or(false),
            wav_format,
            full_scale,
            sample_rate_given: o.sample_rate_hz.is_some(),
        })
    }

    /// The one speed change of `output` (sinusoidal modulation, random drift or ramp), validated.
    fn speed_change(&self, o: &RawOutput, duration_s: f64) -> Result<Option<SpeedChange>, SceneError> {
        let given = [o.speed_modulation.is_some(), o.speed_drift.is_some(), o.speed_ramp.is_some()];
        if given.iter().filter(|g| **g).count() > 1 {
            return Err(self.err(
                "output.speed_modulation",
                "give at most one of speed_modulation, speed_drift and speed_ramp".to_string(),
            ));
        }
        if let Some(m) = &o.speed_modulation {
            if !(m.depth.is_finite() && m.depth >= 0.0 && m.depth < 0.5) {
                return Err(self.err("output.speed_modulation.depth", format!("must be in [0, 0.5), got {}", m.depth)));
            }
            let frequency_hz = self.positive("output.speed_modulation.frequency_hz", m.frequency_hz)?;
            return Ok(Some(SpeedChange::Sinusoidal { depth: m.depth, frequency_hz }));
        }
        if let Some(d) = &o.speed_drift {
            if !(d.ppm.is_finite() && d.ppm > 0.0 && d.ppm <= 2e5) {
                return Err(self.err("output.speed_drift.ppm", format!("must be in (0, 200000], got {}", d.ppm)));
            }
            let time_scale_s = self.positive("output.speed_drift.time_scale_s", d.time_scale_s)?;
            return Ok(Some(SpeedChange::Drift { ppm: d.ppm, time_scale_s, seed: o.seed.unwrap_or(1) }));
        }
        if let Some(r) = &o.speed_ramp {
            for (field, v) in [("output.speed_ramp.from", r.from), ("output.speed_ramp.to", r.to)] {
                if !(v.is_finite() && (0.1..=10.0).contains(&v)) {
                    return Err(self.err(field, format!("must be a relative speed in [0.1, 10], got {v}")));
                }
            }
            return Ok(Some(SpeedChange::Ramp { from: r.from, to: r.to, duration_s }));
        }
        Ok(None)
    }

    pub(super) fn gear_output(&self, o: &RawOutput, g: &GearPair) -> Result<OutputOptions, SceneError> {
        let q = match o.quantity.as_deref() {
            None | Some("velocity") => {
                OutputQuantity::Linear { weights: vec![0.0, 1.0], unit: "m/s".into(), name: "dq/dt".into() }
            }
            Some("displacement") => {
                OutputQuantity::Linear { weights: vec![1.0, 0.0], unit: "m".into(), name: "q".into() }
            }
            Some("acceleration") => {
                OutputQuantity::Derivative { index: 1, unit: "m/s^2".into(), name: "d2q/dt2".into() }
            }
            Some(other) => {
                return Err(self.err(
                    "output.quantity",
                    format!("must be velocity, displacement or acceleration for a gear pair, got \"{other}\""),
                ));
            }
        };
        let z1 = g.params().pinion_teeth as f64;
        let mesh_h = match &g.params().mesh {
            MeshStiffness::Fourier(s) => s.harmonics().max(1) as f64,
            MeshStiffness::Piecewise(_) => 10.0,
        };
        let max_order = (mesh_h + 1.0) * z1;
        // default sample rate: 2.56 x the highest listed frequency, rounded up to a multiple of 1 kHz
        let fs = ((2.56 * max_order * g.pinion_hz()) / 1000.0).ceil() * 1000.0;
        self.common_output(o, q, g.pinion_hz(), "pinion rotation", max_order, fs)
    }

    pub(super) fn press_output(&self, o: &RawOutput, p: &PressParams) -> Result<OutputOptions, SceneError> {
        let q = match o.quantity.as_deref() {
            None | Some("q1") => {
                OutputQuantity::Linear { weights: vec![1.0, 0.0, 0.0, 0.0], unit: "rad".into(), name: "q1".into() }
            }
            Some("q2") => {
                OutputQuantity::Linear { weights: vec![0.0, 1.0, 0.0, 0.0], unit: "m".into(), name: "q2".into() }
            }
            Some("moment") => OutputQuantity::Linear {
                weights: vec![p.k1_n_m_per_rad, 0.0, p.c1_n_m_s_per_rad, 0.0],
                unit: "N m".into(),
                name: "dynamic moment k1 q1 + c1 q1'".into(),
            },
            Some(other) => {
                return Err(
                    self.err("output.quantity", format!("must be q1, q2 or moment for the press, got \"{other}\""))
                );
            }
        };
        let k = p.cam_cos_m_per_rad.len().max(p.cam_sin_m_per_rad.len()) as f64;
        let hz = p.omega_rad_s() / (2.0 * PI);
        self.common_output(o, q, hz, "input shaft rotation", 4.0 * k, 1000.0)
    }

    pub(super) fn ltp_output(
        &self,
        o: &RawOutput,
        sys: &SecondOrderSystem,
        period: f64,
    ) -> Result<OutputOptions, SceneError> {
        let n = sys.dof();
        let spec = o.quantity.clone().unwrap_or_else(|| "y1".into());
        let bad = || self.err("output.quantity", format!("must be y<i> or v<i> with i in 1..={n}, got \"{spec}\""));
        let (kind, idx) = spec.split_at(1.min(spec.len()));
        let i: usize = idx.parse().map_err(|_| bad())?;
        if i < 1 || i > n {
            return Err(bad());
        }
        let mut w = vec![0.0; 2 * n];
        match kind {
            "y" => w[i - 1] = 1.0,
            "v" => w[n + i - 1] = 1.0,
            _ => return Err(bad()),
        }
        let q = OutputQuantity::Linear { weights: w, unit: String::new(), name: spec.clone() };
        let base = 1.0 / period;
        let max_order = (4 * sys.max_harmonic()).max(16) as f64;
        self.common_output(o, q, base, "1/period", max_order, (8.0 * max_order * base).max(1.0))
    }
}
