//! Measured against modelled orders: the comparison scene is simulated at the recording's pinion speed
//! and the pinion orders around the first three mesh harmonics are compared in dB relative to each one's
//! first mesh line (scale-free: the transfer path from mesh to sensor is unknown).

use crate::Error;
use crate::jobs::JobError;
use crate::jobs::simulate::Simulation;
use crate::model::Quantity;
use crate::report::summary::{ComparedLine, Comparison, Diagnosis, Shaft};
use crate::scene::Scene;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;

/// A comparison scene loaded once per call; its simulation is cached for the last speed asked.
pub struct ModelScene {
    scene: Scene,
    cache: Mutex<Option<(f64, Simulation)>>,
}

impl ModelScene {
    /// Loads a gear-pair scene.
    ///
    /// # Errors
    /// The scene cannot be read, or is not a gear pair.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let scene = Scene::load(&path.display().to_string())?;
        if scene.json.get("gear_pair").is_none() {
            return Err(JobError::Input {
                file: scene.file.clone(),
                message: "the comparison scene must be a gear_pair scene".into(),
            }
            .into());
        }
        Ok(Self { scene, cache: Mutex::new(None) })
    }

    /// The scene simulated at `rpm` (pinion speed).
    fn simulate_at(&self, rpm: f64) -> Result<Simulation, Error> {
        let mut cache = self.cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((r, sim)) = cache.as_ref() {
            if (r - rpm).abs() <= 1e-12 * rpm {
                return Ok(sim.clone());
            }
        }
        let mut json = self.scene.json.clone();
        json["gear_pair"]["speed_rpm"] = rpm.into();
        let scene = Scene::from_value(json, &self.scene.file)?;
        let sim = super::super::simulate::simulate(&scene)?;
        *cache = Some((rpm, sim.clone()));
        Ok(sim)
    }
}

fn db(a: f64, r: f64) -> f64 {
    20.0 * (a.max(r * 1e-4) / r).log10()
}

/// Compares the recording's pinion TSA orders with the scene simulated at the measured speed.
///
/// # Errors
/// The scene cannot be solved; the recording has no pinion TSA or sample rate.
pub fn compare(d: &mut Diagnosis, model: &ModelScene, quantity: Quantity) -> Result<(), Error> {
    let scene_path = model.scene.file.clone();
    let shaft_hz = d.shaft_hz.pinion().ok_or_else(|| JobError::Input {
        file: d.file.clone(),
        message: "the model comparison needs the pinion speed in Hz (the teeth and a sample rate)".into(),
    })?;
    let rpm = shaft_hz * 60.0;
    let sim = model.simulate_at(rpm)?;
    let gear = d.gears.iter().find(|g| g.gear == Shaft::Pinion).ok_or_else(|| JobError::Input {
        file: d.file.clone(),
        message: "the model comparison needs the pinion TSA (give the teeth)".into(),
    })?;
    let z = gear.mesh_order;
    let model_lines: BTreeMap<usize, f64> = sim
        .orders
        .iter()
        .filter(|l| (l.order - l.order.round()).abs() < 1e-9)
        .map(|l| (l.order.round() as usize, l.amplitude))
        .collect();
    let w = |order: usize| 2.0 * std::f64::consts::PI * order as f64 * shaft_hz;
    let meas = |o: usize| gear.tsa_amplitudes.get(o).map(|a| quantity.to_velocity(*a, w(o)));
    let (Some(m0), Some(&s0)) = (meas(z), model_lines.get(&z)) else {
        return Err(JobError::Input {
            file: scene_path,
            message: format!("mesh order {z} not available in both the recording and the model"),
        }
        .into());
    };
    let mut lines = Vec::new();
    for k in 1..=3 {
        for i in -3i64..=3 {
            let o = (k * z) as i64 + i;
            let (Some(a), Some(&b)) = (meas(o as usize), model_lines.get(&(o as usize))) else { continue };
            let label = if i == 0 { format!("{k}x mesh") } else { format!("{k}x mesh {i:+} pinion") };
            let (md, sd) = (db(a, m0), db(b, s0));
            lines.push(ComparedLine {
                order: o as usize,
                label,
                measured_db: md,
                model_db: sd,
                difference_db: md - sd,
            });
        }
    }
    let distance = (lines.iter().map(|l| l.difference_db.powi(2)).sum::<f64>() / lines.len().max(1) as f64).sqrt();
    d.comparison = Some(Comparison {
        scene: scene_path,
        model_speed_rpm: rpm,
        scale_at_mesh: m0 / s0,
        distance_db: distance,
        model_misses: lines
            .iter()
            .filter(|l| l.difference_db > 6.0)
            .map(|l| format!("order {} ({}): +{:.1} dB", l.order, l.label, l.difference_db))
            .collect(),
        model_overpredicts: lines
            .iter()
            .filter(|l| l.difference_db < -6.0)
            .map(|l| format!("order {} ({}): {:.1} dB", l.order, l.label, l.difference_db))
            .collect(),
        lines,
    });
    Ok(())
}
