//! Validation of the raw scene into typed model objects: every value checked, every error naming the file
//! and the dotted field path (the `output` object in `output`).

use super::SceneError;
use super::raw::*;
use crate::model::gear::{self, Crack, Gear, ToothFault};
use crate::model::{self, GearPair, GearPairParams, MeshStiffness, PressParams, SecondOrderSystem};
use crate::solver::SolverOptions;
use crate::system::{Coefficient, FourierSeries, PiecewiseConstant};
use std::f64::consts::PI;

/// Most cam coefficients of a press scene (a real cam profile needs tens).
const MAX_CAM_COEFFICIENTS: usize = 1000;
/// Sine-cosine pairs allowed for turning a sampled mesh-stiffness table into its Fourier series (N^2 / 2
/// for N samples: about 1.5 s on one core of the development machine; 100000 samples took 77 s).
const TABLE_BUDGET: f64 = 1e8;
/// Highest order of a tooth error, and most harmonics of a tooth-fault series.
const MAX_ERROR_ORDER: usize = 100_000;
/// Terms (faults times harmonics) of the tooth-fault series (about a second).
const FAULT_BUDGET: f64 = 1e8;
/// Smallest accepted `solver.tolerance`.
const MIN_TOLERANCE: f64 = 1e-15;
/// Largest accepted mesh damping ratio (critical damping is 1).
const MAX_DAMPING_RATIO: f64 = 10.0;
/// Largest accepted ratio between the mesh natural frequency and the mesh frequency (either way).
const MAX_FREQUENCY_RATIO: f64 = 1e5;

pub(super) struct Validator<'a> {
    file: &'a str,
}

impl Validator<'_> {
    pub(super) fn new(file: &str) -> Validator<'_> {
        Validator { file }
    }
    pub(super) fn err(&self, field: &str, message: String) -> SceneError {
        SceneError::Invalid { file: self.file.to_string(), field: field.to_string(), message }
    }
    pub(super) fn positive(&self, field: &str, x: f64) -> Result<f64, SceneError> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(field, format!("must be a positive number, got {x}")))
        }
    }
    pub(super) fn non_negative(&self, field: &str, x: f64) -> Result<f64, SceneError> {
        if x.is_finite() && x >= 0.0 { Ok(x) } else { Err(self.err(field, format!("must be >= 0, got {x}"))) }
    }
    pub(super) fn finite(&self, field: &str, x: f64) -> Result<f64, SceneError> {
        if x.is_finite() { Ok(x) } else { Err(self.err(field, format!("must be finite, got {x}"))) }
    }

    pub(super) fn solver(&self, s: &RawSolver) -> Result<SolverOptions, SceneError> {
        let mut o = SolverOptions::default();
        if let Some(m) = s.method {
            o.method = m;
        }
        if let Some(t) = s.tolerance {
            // below about 5 machine epsilons no estimate can certify a 64-bit solution: 1e-308 was accepted
            // and spent 20 s of ever finer rk4 grids before its refusal
            if !(t.is_finite() && (MIN_TOLERANCE..1.0).contains(&t)) {
                return Err(self.err(
                    "solver.tolerance",
                    format!("must be in [{MIN_TOLERANCE:e}, 1) (64-bit rounding is about 2e-16), got {t}"),
                ));
            }
            o.tolerance = t;
        }
        if let Some(h) = s.harmonics {
            if !(1..=1_000_000).contains(&h) {
                return Err(self.err("solver.harmonics", format!("must be in 1..=1000000, got {h}")));
            }
            o.harmonics = Some(h as usize);
        }
        if let Some(n) = s.steps {
            if n < 1 || n > o.max_steps as u64 {
                return Err(self.err("solver.steps", format!("must be in 1..={}, got {n}", o.max_steps)));
            }
            o.steps = Some(n as usize);
        }
        Ok(o)
    }

    pub(super) fn errors(&self, field: &str, list: &[RawHarmonic]) -> Result<FourierSeries, SceneError> {
        let mut terms = Vec::new();
        for (i, h) in list.iter().enumerate() {
            let f = format!("{field}[{i}]");
            if h.order == 0 || h.order as usize > MAX_ERROR_ORDER {
                return Err(
                    self.err(&format!("{f}.order"), format!("must be in 1..={MAX_ERROR_ORDER}, got {}", h.order))
                );
            }
            self.non_negative(&format!("{f}.amplitude_m"), h.amplitude_m)?;
            self.finite(&format!("{f}.phase_rad"), h.phase_rad)?;
            terms.push((h.order as usize, h.amplitude_m, h.phase_rad));
        }
        Ok(FourierSeries::from_amplitude_phase(1.0, 0.0, &terms))
    }

    /// Local profile deviation on single teeth: a Gaussian bump of height `depth_m` (positive = material
    /// missing, adds to e(t)) centred on the tooth's mesh cycle with 6 sigma = `width_teeth` pitches, as a
    /// Fourier series in the gear angle. Its spectrum decays like exp(-(k sigma)^2 / 2), so few harmonics
    /// meet the tolerance.
    pub(super) fn tooth_faults(
        &self,
        field: &str,
        teeth: u32,
        faults: &[RawToothFault],
        tolerance: f64,
        notes: &mut Vec<String>,
    ) -> Result<FourierSeries, SceneError> {
        if faults.is_empty() {
            return Ok(FourierSeries::constant(0.0));
        }
        let keep = tolerance.max(1e-7);
        let mut list = Vec::with_capacity(faults.len());
        for (i, f) in faults.iter().enumerate() {
            let fld = format!("{field}[{i}]");
            if f.tooth < 1 || f.tooth > teeth {
                return Err(self.err(&format!("{fld}.tooth"), format!("must be in 1..={teeth}, got {}", f.tooth)));
            }
            self.finite(&format!("{fld}.depth_m"), f.depth_m)?;
            if !(f.width_teeth.is_finite() && f.width_teeth > 0.0 && f.width_teeth <= teeth as f64) {
                return Err(
                    self.err(&format!("{fld}.width_teeth"), format!("must be in (0, {teeth}], got {}", f.width_teeth))
                );
            }
            list.push(ToothFault { tooth: f.tooth as usize, depth_m: f.depth_m, width_teeth: f.width_teeth });
        }
        // the narrowest fault sets the series' harmonics (a width of 1e-9 pitches asked for 6e11 bytes and
        // aborted), each fault costs them all
        let (narrowest, width) = list
            .iter()
            .enumerate()
            .map(|(i, f)| (i, f.width_teeth))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let h = gear::gaussian_harmonics(teeth as usize, width, keep);
        if h.is_nan() || h > MAX_ERROR_ORDER as f64 {
            return Err(self.err(
                &format!("{field}[{narrowest}].width_teeth"),
                format!(
                    "{width} pitches on {teeth} teeth needs {h:.2e} harmonics of the gear angle (at most {MAX_ERROR_ORDER}, as for errors): widen it to at least {:.3e} pitches",
                    width * h / MAX_ERROR_ORDER as f64
                ),
            ));
        }
        let work = h * list.len() as f64;
        if work > FAULT_BUDGET {
            return Err(self.err(
                field,
                format!(
                    "{} faults of {} harmonics each: about {work:.1e} terms, beyond the budget of {FAULT_BUDGET:.0e}",
                    list.len(),
                    h.ceil()
                ),
            ));
        }
        let mut series = gear::gaussian_tooth_faults(teeth as usize, &list, keep);
        let dropped = series.truncate_below(keep * series.max_amplitude());
        notes.push(format!(
            "{field}: Gaussian profile deviation as {} harmonics (terms below {:.1e} of the largest dropped, {} more)",
            series.harmonics(),
            keep,
            dropped
        ));
        Ok(series)
    }

    pub(super) fn gear(&self, field: &str, g: &RawGear) -> Result<(), SceneError> {
        if g.teeth < 3 || g.teeth > 100_000 {
            return Err(
                self.err(&format!("{field}.teeth"), format!("must be an integer in 3..=100000, got {}", g.teeth))
            );
        }
        self.positive(&format!("{field}.inertia_kg_m2"), g.inertia_kg_m2)?;
        self.positive(&format!("{field}.base_radius_m"), g.base_radius_m)?;
        Ok(())
    }

    pub(super) fn mesh(
        &self,
        m: &RawMesh,
        tolerance: f64,
        notes: &mut Vec<String>,
    ) -> Result<MeshStiffness, SceneError> {
        let f = "gear_pair.mesh_stiffness";
        match m {
            RawMesh::Fourier { mean_n_per_m, harmonics } => {
                let mean = self.positive(&format!("{f}.fourier.mean_n_per_m"), *mean_n_per_m)?;
                let mut terms = Vec::new();
                let mut sum = 0.0;
                for (i, h) in harmonics.iter().enumerate() {
                    let a = self
                        .non_negative(&format!("{f}.fourier.harmonics[{i}].amplitude_n_per_m"), h.amplitude_n_per_m)?;
                    self.finite(&format!("{f}.fourier.harmonics[{i}].phase_rad"), h.phase_rad)?;
                    sum += a;
                    terms.push((i + 1, a, h.phase_rad));
                }
                if sum >= mean {
                    return Err(self.err(
                        &format!("{f}.fourier.harmonics"),
                        format!("harmonic amplitudes add up to {sum:e} N/m, not below the mean {mean:e}: the stiffness could turn negative"),
                    ));
                }
                Ok(MeshStiffness::Fourier(FourierSeries::from_amplitude_phase(1.0, mean, &terms)))
            }
            RawMesh::Rectangular { contact_ratio, pair_stiffness_n_per_m } => {
                let eps = *contact_ratio;
                if !(eps.is_finite() && (1.0..3.0).contains(&eps)) {
                    return Err(
                        self.err(&format!("{f}.rectangular.contact_ratio"), format!("must be in [1, 3), got {eps}"))
                    );
                }
                let kp = self.positive(&format!("{f}.rectangular.pair_stiffness_n_per_m"), *pair_stiffness_n_per_m)?;
                let (lo, frac) = (eps.floor(), eps - eps.floor());
                let p = gear::rectangular_stiffness(eps, kp);
                notes.push(format!(
                    "rectangular mesh stiffness: {} pairs for {:.3} of each mesh cycle",
                    lo + 1.0,
                    frac
                ));
                Ok(MeshStiffness::Piecewise(p))
            }
            RawMesh::Samples { values_n_per_m } => {
                if values_n_per_m.len() < 3 {
                    return Err(self.err(
                        &format!("{f}.samples.values_n_per_m"),
                        "needs at least 3 samples over one mesh cycle".into(),
                    ));
                }
                let n = values_n_per_m.len() as f64;
                let work = n * n / 2.0;
                if work > TABLE_BUDGET {
                    return Err(self.err(
                        &format!("{f}.samples.values_n_per_m"),
                        format!(
                            "{n} samples: their Fourier series would take about {work:.1e} sine-cosine evaluations (~{:.0} s), beyond the budget of {TABLE_BUDGET:.0e}: give at most {} samples over the mesh cycle",
                            work * 15e-9,
                            (2.0 * TABLE_BUDGET).sqrt().floor()
                        ),
                    ));
                }
                for (i, x) in values_n_per_m.iter().enumerate() {
                    if !(x.is_finite() && *x > 0.0) {
                        self.positive(&format!("{f}.samples.values_n_per_m[{i}]"), *x)?;
                    }
                }
                let mut s = FourierSeries::from_samples(1.0, values_n_per_m, values_n_per_m.len() / 2);
                let dropped = s.truncate_below(tolerance * s.mean);
                notes.push(format!(
                    "mesh stiffness from {} samples: {} harmonics kept, {} dropped below {:.1e} of the mean",
                    values_n_per_m.len(),
                    s.harmonics(),
                    dropped,
                    tolerance
                ));
                Ok(MeshStiffness::Fourier(s))
            }
        }
    }

    pub(super) fn gear_pair(
        &self,
        g: &RawGearPair,
        tolerance: f64,
        notes: &mut Vec<String>,
    ) -> Result<GearPair, SceneError> {
        let f = "gear_pair";
        self.positive(&format!("{f}.speed_rpm"), g.speed_rpm)?;
        self.non_negative(&format!("{f}.damping_ratio"), g.damping_ratio)?;
        if g.damping_ratio > MAX_DAMPING_RATIO {
            return Err(self.err(
                &format!("{f}.damping_ratio"),
                format!(
                    "{} is beyond any gear mesh (critical damping is 1; at most {MAX_DAMPING_RATIO})",
                    g.damping_ratio
                ),
            ));
        }
        self.finite(&format!("{f}.static_deflection_m"), g.static_deflection_m)?;
        self.gear(&format!("{f}.pinion"), &g.pinion)?;
        self.gear(&format!("{f}.wheel"), &g.wheel)?;
        let mesh = self.mesh(&g.mesh_stiffness, tolerance, notes)?;
        let mut pinion_errors = self.errors(&format!("{f}.pinion.errors"), &g.pinion.errors)?;
        let mut wheel_errors = self.errors(&format!("{f}.wheel.errors"), &g.wheel.errors)?;
        let pf = self.tooth_faults(
            &format!("{f}.pinion.tooth_faults"),
            g.pinion.teeth,
            &g.pinion.tooth_faults,
            tolerance,
            notes,
        )?;
        let wf = self.tooth_faults(
            &format!("{f}.wheel.tooth_faults"),
            g.wheel.teeth,
            &g.wheel.tooth_faults,
            tolerance,
            notes,
        )?;
        pinion_errors = pinion_errors.plus(&pf);
        wheel_errors = wheel_errors.plus(&wf);
        let crack = match &g.crack {
            None => None,
            Some(c) => {
                let (gear, teeth) = match c.gear {
                    Gear::Pinion => (Gear::Pinion, g.pinion.teeth),
                    Gear::Wheel => (Gear::Wheel, g.wheel.teeth),
                };
                if c.tooth < 1 || c.tooth > teeth {
                    return Err(
                        self.err(&format!("{f}.crack.tooth"), format!("must be in 1..={teeth}, got {}", c.tooth))
                    );
                }
                if !(c.stiffness_loss.is_finite() && c.stiffness_loss > 0.0 && c.stiffness_loss < 1.0) {
                    return Err(self.err(
                        &format!("{f}.crack.stiffness_loss"),
                        format!("must be in (0, 1), got {}", c.stiffness_loss),
                    ));
                }
                Some(Crack { gear, tooth: c.tooth as usize, loss: c.stiffness_loss })
            }
        };
        let params = GearPairParams {
            pinion_teeth: g.pinion.teeth as usize,
            wheel_teeth: g.wheel.teeth as usize,
            pinion_inertia_kg_m2: g.pinion.inertia_kg_m2,
            wheel_inertia_kg_m2: g.wheel.inertia_kg_m2,
            pinion_base_radius_m: g.pinion.base_radius_m,
            wheel_base_radius_m: g.wheel.base_radius_m,
            speed_rpm: g.speed_rpm,
            damping_ratio: g.damping_ratio,
            static_deflection_m: g.static_deflection_m,
            mesh,
            pinion_errors,
            wheel_errors,
            crack,
        };
        let gp = GearPair::new(params);
        self.plausible_natural_frequency(g, &gp)?;
        if gp.mesh_cycles_per_period() > 200_000 {
            return Err(self.err(
                &format!("{f}.wheel.teeth"),
                format!(
                    "the scene's period holds {} mesh cycles, more than 200000 would need absurd memory",
                    gp.mesh_cycles_per_period()
                ),
            ));
        }
        notes.push(format!(
            "gear pair: w0 = {:.1} 1/s ({:.1} Hz), mesh {:.1} Hz, m_red = {:.4} kg, period = {} pinion rev ({} mesh cycles)",
            gp.natural_frequency_rad_s(),
            gp.natural_frequency_rad_s() / (2.0 * PI),
            gp.mesh_hz(),
            gp.reduced_mass_kg(),
            fmt_revs(gp.revolutions_per_period()),
            gp.mesh_cycles_per_period()
        ));
        Ok(gp)
    }

    /// A gear pair without a Fourier form is time-stepped over its whole period, and the output's orders
    /// are integrated on every step: refused when the estimate of that work ([`GearPair::stepped_work`])
    /// is beyond the solver's budget (a crack on the wheel makes the period the hunting period).
    pub(super) fn gear_work(&self, gp: &GearPair, max_order: f64, tolerance: f64) -> Result<(), SceneError> {
        let Some(work) = gp.stepped_work(max_order, tolerance) else { return Ok(()) };
        if work.total() <= crate::solver::WORK_BUDGET_FLOPS {
            return Ok(());
        }
        Err(self.err(
            if gp.params().crack.is_some() { "gear_pair.crack" } else { "gear_pair.mesh_stiffness" },
            format!(
                "no Fourier form (a crack or a piecewise mesh stiffness), so time steps over the period of {} pinion revolutions ({} mesh cycles): about {} steps and {:.1e} floating-point operations with the output's {} orders, beyond the budget of {:.0e}: put the crack on the pinion (a period of one revolution), lower output.max_order, or give a smooth mesh stiffness",
                fmt_revs(gp.revolutions_per_period()),
                gp.mesh_cycles_per_period(),
                work.steps,
                work.total(),
                work.orders,
                crate::solver::WORK_BUDGET_FLOPS
            ),
        ))
    }

    /// The mesh's natural frequency must be a finite, sensible multiple of the mesh frequency: an inertia
    /// or base radius off by many orders of magnitude gives a mode no scene needs (and step grids beyond any
    /// memory). The gear with the smaller J / rb^2 sets the reduced mass and is named.
    fn plausible_natural_frequency(&self, g: &RawGearPair, gp: &GearPair) -> Result<(), SceneError> {
        let f0 = gp.natural_frequency_rad_s() / (2.0 * PI);
        let ratio = f0 / gp.mesh_hz();
        if ratio.is_finite() && (1.0 / MAX_FREQUENCY_RATIO..=MAX_FREQUENCY_RATIO).contains(&ratio) {
            return Ok(());
        }
        let m1 = g.pinion.inertia_kg_m2 / g.pinion.base_radius_m.powi(2);
        let m2 = g.wheel.inertia_kg_m2 / g.wheel.base_radius_m.powi(2);
        let gear = if m1.is_nan() || m1 < m2 { "pinion" } else { "wheel" };
        let gear =
            if ratio < 1.0 / MAX_FREQUENCY_RATIO { if gear == "pinion" { "wheel" } else { "pinion" } } else { gear };
        Err(self.err(
            &format!("gear_pair.{gear}.inertia_kg_m2"),
            format!(
                "with gear_pair.{gear}.base_radius_m and the mean mesh stiffness it gives a mesh natural frequency of {f0:.3e} Hz, {ratio:.1e} times the mesh frequency {:.3e} Hz (allowed 1e-5 .. 1e5): check the inertias, base radii and stiffness",
                gp.mesh_hz()
            ),
        ))
    }

    pub(super) fn press(&self, p: &RawPress) -> Result<PressParams, SceneError> {
        let f = "press";
        let cos = p.cam_cos_m_per_rad.clone();
        for (i, x) in cos.iter().chain(&p.cam_sin_m_per_rad).enumerate() {
            self.finite(&format!("{f}.cam coefficient {i}"), *x)?;
        }
        let count = cos.len().max(p.cam_sin_m_per_rad.len());
        if count > MAX_CAM_COEFFICIENTS {
            return Err(self.err(
                &format!("{f}.cam_cos_m_per_rad"),
                format!(
                    "{count} cam coefficients, at most {MAX_CAM_COEFFICIENTS}: the press equations multiply the cam series, so the work grows with the square of their number"
                ),
            ));
        }
        if cos.is_empty() && p.cam_sin_m_per_rad.is_empty() {
            return Err(self.err(&format!("{f}.cam_cos_m_per_rad"), "at least one cam coefficient is needed".into()));
        }
        let params = PressParams {
            speed_rpm: self.positive(&format!("{f}.speed_rpm"), p.speed_rpm)?,
            k1_n_m_per_rad: self
                .positive(&format!("{f}.torsional_stiffness_n_m_per_rad"), p.torsional_stiffness_n_m_per_rad)?,
            k2_n_per_m: self.positive(&format!("{f}.follower_stiffness_n_per_m"), p.follower_stiffness_n_per_m)?,
            c1_n_m_s_per_rad: self
                .non_negative(&format!("{f}.torsional_damping_n_m_s_per_rad"), p.torsional_damping_n_m_s_per_rad)?,
            c2_n_s_per_m: self
                .non_negative(&format!("{f}.follower_damping_n_s_per_m"), p.follower_damping_n_s_per_m)?,
            inertia_kg_m2: self.positive(&format!("{f}.cam_inertia_kg_m2"), p.cam_inertia_kg_m2)?,
            mass_kg: self.positive(&format!("{f}.follower_mass_kg"), p.follower_mass_kg)?,
            load_n: self.finite(&format!("{f}.load_n"), p.load_n)?,
            cam_cos_m_per_rad: cos,
            cam_sin_m_per_rad: p.cam_sin_m_per_rad.clone(),
        };
        self.press_damping(&params)?;
        Ok(params)
    }

    /// Each press damping relative to its critical value 2 sqrt(k m) (the paper's is 0.1): beyond
    /// `MAX_DAMPING_RATIO` it is no press (and a torsional damping of 1e6 N m s/rad, ratio 5400, made the
    /// system so stiff that the solve took 20 s).
    fn press_damping(&self, p: &PressParams) -> Result<(), SceneError> {
        for (field, c, k, m) in [
            ("press.torsional_damping_n_m_s_per_rad", p.c1_n_m_s_per_rad, p.k1_n_m_per_rad, p.inertia_kg_m2),
            ("press.follower_damping_n_s_per_m", p.c2_n_s_per_m, p.k2_n_per_m, p.mass_kg),
        ] {
            let ratio = c / (2.0 * (k * m).sqrt());
            if ratio.is_nan() || ratio > MAX_DAMPING_RATIO {
                return Err(self.err(
                    field,
                    format!(
                        "{c} is {ratio:.3e} times the critical damping 2 sqrt(k m) = {:.4e}: beyond any press (at most {MAX_DAMPING_RATIO})",
                        2.0 * (k * m).sqrt()
                    ),
                ));
            }
        }
        Ok(())
    }

    pub(super) fn entry(&self, field: &str, e: &RawEntry, period: f64) -> Result<Coefficient, SceneError> {
        if let Some(st) = &e.steps {
            if e.mean.is_some() || !e.cos.is_empty() || !e.sin.is_empty() {
                return Err(self.err(field, "give either `steps` or `mean`/`cos`/`sin`, not both".into()));
            }
            if st.starts_s.is_empty() || st.starts_s.len() != st.values.len() {
                return Err(self.err(
                    &format!("{field}.steps"),
                    "starts_s and values must be non-empty and of equal length".into(),
                ));
            }
            if st.starts_s[0] != 0.0
                || st.starts_s.windows(2).any(|w| w[1] <= w[0])
                || st.starts_s.iter().any(|s| *s >= period || !s.is_finite())
            {
                return Err(self.err(
                    &format!("{f}.steps.starts_s", f = field),
                    "must start at 0, increase strictly and stay below period_s".into(),
                ));
            }
            for (i, v) in st.values.iter().enumerate() {
                self.finite(&format!("{field}.steps.values[{i}]"), *v)?;
            }
            return Ok(Coefficient::Piecewise(PiecewiseConstant {
                period_s: period,
                starts: st.starts_s.clone(),
                values: st.values.clone(),
            }));
        }
        let mean = self.finite(&format!("{field}.mean"), e.mean.unwrap_or(0.0))?;
        for (i, v) in e.cos.iter().enumerate() {
            self.finite(&format!("{field}.cos[{i}]"), *v)?;
        }
        for (i, v) in e.sin.iter().enumerate() {
            self.finite(&format!("{field}.sin[{i}]"), *v)?;
        }
        Ok(Coefficient::Fourier(FourierSeries::new(2.0 * PI / period, mean, e.cos.clone(), e.sin.clone())))
    }

    pub(super) fn matrix(
        &self,
        name: &str,
        rows: &[Vec<RawEntry>],
        n: usize,
        period: f64,
    ) -> Result<Vec<Coefficient>, SceneError> {
        if rows.len() != n {
            return Err(self.err(
                &format!("ltp.{name}"),
                format!("has {} rows, expected {n} (the length of `forcing`)", rows.len()),
            ));
        }
        let mut out = Vec::with_capacity(n * n);
        for (i, row) in rows.iter().enumerate() {
            if row.len() != n {
                return Err(self.err(&format!("ltp.{name}[{i}]"), format!("has {} entries, expected {n}", row.len())));
            }
            for (j, e) in row.iter().enumerate() {
                out.push(self.entry(&format!("ltp.{name}[{i}][{j}]"), e, period)?);
            }
        }
        Ok(out)
    }

    pub(super) fn ltp(&self, l: &RawLtp) -> Result<SecondOrderSystem, SceneError> {
        let period = self.positive("ltp.period_s", l.period_s)?;
        let n = l.forcing.len();
        if n == 0 || n > 64 {
            return Err(
                self.err("ltp.forcing", format!("must have 1..=64 entries (one per degree of freedom), got {n}"))
            );
        }
        let mass = self.matrix("mass", &l.mass, n, period)?;
        let damping = self.matrix("damping", &l.damping, n, period)?;
        let stiffness = self.matrix("stiffness", &l.stiffness, n, period)?;
        let forcing = l
            .forcing
            .iter()
            .enumerate()
            .map(|(i, e)| self.entry(&format!("ltp.forcing[{i}]"), e, period))
            .collect::<Result<Vec<_>, _>>()?;
        let sys = SecondOrderSystem::new(period, mass, damping, stiffness, forcing).map_err(|e| match e {
            model::second_order::BuildError::SingularMass { t } => {
                self.err("ltp.mass", format!("mass matrix is singular at t = {t:.6} s"))
            }
            model::second_order::BuildError::MassNotPositiveDefinite { t } => self.err(
                "ltp.mass",
                format!("mass matrix is not symmetric positive definite at t = {t:.6} s (masses must be positive)"),
            ),
            model::second_order::BuildError::Size { what, expected, got } => {
                self.err(&format!("ltp.{what}"), format!("has {got} entries, expected {expected}"))
            }
        })?;
        // modes that turn more than 1e6 times per period need more RK4 steps than any scene should ask for
        let rate = crate::solver::rate_at(&sys, 4);
        let turns = rate * period / (2.0 * PI);
        if !turns.is_finite() || turns > 1e6 {
            let field = if rate.is_finite() && rate < 1e6 { "ltp.period_s" } else { "ltp.stiffness" };
            return Err(self.err(
                field,
                format!(
                    "the fastest mode (|lambda| = {rate:.3e} 1/s) turns {turns:.2e} times per period of {period:.3e} s (at most 1e6): check period_s and the mass, damping and stiffness entries"
                ),
            ));
        }
        Ok(sys)
    }
}

pub(super) fn fmt_revs(r: f64) -> String {
    if (r - r.round()).abs() < 1e-9 { format!("{}", r.round()) } else { format!("{r:.4}") }
}
