//! `gear_train` scenes: a machine file's chain of parallel stages with each gear's inertia, base radius and
//! errors, each mesh's stiffness and damping, each shaft's torsional stiffness, the speed and the load.
//! Only `simulate` takes them (a train whose stages share no short period has no single periodic system).
//!
//! ```json
//! {"model": "gear_train",
//!  "gear_train": {"machine": "../machines/two-stage-z23z61-z19z47.json", "speed_rpm": 1480, "load_torque_n_m": 100,
//!    "shafts": [{"torsional_stiffness_n_m_per_rad": 5e4, "torsional_damping_n_m_s_per_rad": 5}, ...one per machine shaft],
//!    "stages": [{"pinion": {"teeth": 23, "inertia_kg_m2": 0.01, "base_radius_m": 0.04, "errors": [...]},
//!                "wheel": {...}, "mesh_stiffness": {"fourier": {"mean_n_per_m": 2e8, "harmonics": [...]}},
//!                "damping_ratio": 0.05}, ...one per machine stage]},
//!  "solver": {"tolerance": 1e-8}, "output": {"sample_rate_hz": 20000, "duration_s": 2}}
//! ```
//! `speed_rpm` is the speed of the machine's reference shaft (its `speed.shaft`, else its tachometer's
//! shaft, else its first shaft); `machine` is relative to the scene file's directory.

use super::SceneError;
use super::raw::{RawGear, RawMesh, RawSolver};
use super::validate::Validator;
use crate::model::gear_train::{GearTrain, TrainGear, TrainShaft, TrainStage};
use crate::model::kinematics::{Machine, Stage};
use crate::solver::SolverOptions;
use crate::system::FourierSeries;
use serde::Deserialize;

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
enum TrainKind {
    GearTrain,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawTrainScene {
    #[serde(default)]
    name: Option<String>,
    /// Free text for people; accepted, not used.
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    #[allow(dead_code)]
    model: TrainKind,
    gear_train: RawGearTrain,
    #[serde(default)]
    solver: RawSolver,
    #[serde(default)]
    output: RawTrainOutput,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawGearTrain {
    machine: String,
    speed_rpm: f64,
    load_torque_n_m: f64,
    shafts: Vec<RawTrainShaft>,
    stages: Vec<RawTrainStage>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawTrainShaft {
    torsional_stiffness_n_m_per_rad: f64,
    #[serde(default)]
    torsional_damping_n_m_s_per_rad: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawTrainStage {
    pinion: RawGear,
    wheel: RawGear,
    mesh_stiffness: RawMesh,
    damping_ratio: f64,
}

#[derive(Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
struct RawTrainOutput {
    #[serde(default)]
    sample_rate_hz: Option<f64>,
    #[serde(default)]
    duration_s: Option<f64>,
}

/// What a gear-train simulation writes.
#[derive(Clone, Debug)]
pub struct TrainOutput {
    /// Sample rate of a written recording, Hz (default 20 kHz).
    pub sample_rate_hz: f64,
    /// Duration of a written recording, s (default 1 s).
    pub duration_s: f64,
}

/// A validated `gear_train` scene.
#[derive(Clone, Debug)]
pub struct TrainScene {
    /// Scene name (file stem when not given).
    pub name: String,
    /// Path it was read from.
    pub file: String,
    /// The machine file's gearbox (shafts, stages, sensors, tachometer).
    pub machine: Machine,
    /// The dynamic model.
    pub train: GearTrain,
    /// Solver options (tolerance).
    pub solver: SolverOptions,
    /// Recording options.
    pub output: TrainOutput,
    /// What was modelled, in plain words.
    pub notes: Vec<String>,
}

/// Longest recording a scene may ask for, s.
const MAX_DURATION_S: f64 = 3600.0;

/// True when `path` holds a JSON object whose `model` is "gear_train" (anything else, unreadable files
/// included, is left to the ordinary scene loader and its messages).
pub fn is_gear_train(path: &str) -> bool {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_some_and(|v| v.get("model").and_then(|m| m.as_str()) == Some("gear_train"))
}

impl TrainScene {
    /// Reads and validates a `gear_train` scene and the machine file it names.
    ///
    /// # Errors
    /// [`SceneError`] naming the file (the scene's or the machine's) and the field.
    pub fn load(path: &str) -> Result<Self, SceneError> {
        crate::io::register_input(std::path::Path::new(path));
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError::Io { file: path.to_string(), message: e.to_string() })?;
        let mut de = serde_json::Deserializer::from_str(&text);
        let raw: RawTrainScene = serde_path_to_error::deserialize(&mut de).map_err(|e| super::json_error(path, e))?;
        let dir = std::path::Path::new(path).parent().unwrap_or(std::path::Path::new("."));
        let machine_path = dir.join(&raw.gear_train.machine);
        let machine = super::machine::load_machine(&machine_path.display().to_string())?;
        let v = Validator::new(path);
        let solver = v.solver(&raw.solver)?;
        let mut notes = Vec::new();
        let train = build(&v, &raw.gear_train, &machine, solver.tolerance, &mut notes)?;
        let output = TrainOutput {
            sample_rate_hz: v.positive("output.sample_rate_hz", raw.output.sample_rate_hz.unwrap_or(20_000.0))?,
            duration_s: v.positive("output.duration_s", raw.output.duration_s.unwrap_or(1.0))?,
        };
        if output.duration_s > MAX_DURATION_S {
            return Err(v.err("output.duration_s", format!("at most {MAX_DURATION_S} s, got {}", output.duration_s)));
        }
        let stem = std::path::Path::new(path).file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
        let name = raw.name.clone().unwrap_or_else(|| stem.to_string());
        Ok(Self { name, file: path.to_string(), machine, train, solver, output, notes })
    }
}

/// The stages of `machine` as a chain: stage k+1 driven by stage k's driven shaft; the shaft order along it.
fn chain(v: &Validator<'_>, machine: &Machine) -> Result<Vec<usize>, SceneError> {
    let mut order = Vec::new();
    for (k, s) in machine.stages.iter().enumerate() {
        let Stage::Parallel(p) = s else {
            return Err(v.err(
                "gear_train.machine",
                format!("the machine's stage {} is planetary: a gear_train models parallel stages only", k + 1),
            ));
        };
        if k == 0 {
            order.push(p.driving);
        } else if order.last() != Some(&p.driving) {
            return Err(v.err(
                "gear_train.machine",
                format!(
                    "the machine's stage {} is not driven by stage {}'s driven shaft: a gear_train models a chain of stages",
                    k + 1,
                    k
                ),
            ));
        }
        order.push(p.driven);
    }
    if order.len() != machine.shafts.len() {
        return Err(v.err("gear_train.machine", "the machine has shafts outside the chain of its stages".into()));
    }
    Ok(order)
}

fn build(
    v: &Validator<'_>,
    g: &RawGearTrain,
    machine: &Machine,
    tolerance: f64,
    notes: &mut Vec<String>,
) -> Result<GearTrain, SceneError> {
    let f = "gear_train";
    let order = chain(v, machine)?;
    let speed_rpm = v.positive(&format!("{f}.speed_rpm"), g.speed_rpm)?;
    let load = v.finite(&format!("{f}.load_torque_n_m"), g.load_torque_n_m)?;
    if g.stages.len() != machine.stages.len() {
        return Err(v.err(
            &format!("{f}.stages"),
            format!("has {} stages, the machine {}", g.stages.len(), machine.stages.len()),
        ));
    }
    if g.shafts.len() != machine.shafts.len() {
        return Err(v.err(
            &format!("{f}.shafts"),
            format!(
                "has {} shafts, the machine {} ({})",
                g.shafts.len(),
                machine.shafts.len(),
                machine.shafts.join(", ")
            ),
        ));
    }
    let mut shafts = Vec::with_capacity(order.len());
    for &i in &order {
        let fs = format!("{f}.shafts[{i}]");
        let s = &g.shafts[i];
        shafts.push(TrainShaft {
            stiffness_n_m_per_rad: v
                .positive(&format!("{fs}.torsional_stiffness_n_m_per_rad"), s.torsional_stiffness_n_m_per_rad)?,
            damping_n_m_s_per_rad: v
                .non_negative(&format!("{fs}.torsional_damping_n_m_s_per_rad"), s.torsional_damping_n_m_s_per_rad)?,
        });
    }
    let mut stages = Vec::with_capacity(g.stages.len());
    for (k, (raw, st)) in g.stages.iter().zip(&machine.stages).enumerate() {
        let Stage::Parallel(p) = st else { unreachable!("chain() checked every stage is parallel") };
        let fk = format!("{f}.stages[{k}]");
        let pinion = gear(v, &format!("{fk}.pinion"), &raw.pinion, p.driving_teeth, tolerance, notes)?;
        let wheel = gear(v, &format!("{fk}.wheel"), &raw.wheel, p.driven_teeth, tolerance, notes)?;
        let mesh = mesh(v, &format!("{fk}.mesh_stiffness"), &raw.mesh_stiffness)?;
        let zeta = v.non_negative(&format!("{fk}.damping_ratio"), raw.damping_ratio)?;
        if zeta > 10.0 {
            return Err(v.err(&format!("{fk}.damping_ratio"), format!("{zeta} is beyond any gear mesh (at most 10)")));
        }
        stages.push(TrainStage { pinion, wheel, mesh, damping_ratio: zeta, pinion_order: machine.order(p.driving) });
    }
    let train = GearTrain { stages, shafts, speed_hz: speed_rpm / 60.0, load_torque_n_m: load };
    for (k, hz) in train.stage_base_hz().iter().enumerate() {
        notes.push(format!(
            "stage {}: mesh {:.3} Hz, its coefficients repeat every {:.6} s ({} pinion revolutions)",
            k + 1,
            machine.mesh_hz(train.speed_hz)[k],
            1.0 / hz,
            train.stages[k].revolutions()
        ));
    }
    Ok(train)
}

fn gear(
    v: &Validator<'_>,
    field: &str,
    g: &RawGear,
    teeth: u32,
    tolerance: f64,
    notes: &mut Vec<String>,
) -> Result<TrainGear, SceneError> {
    v.gear(field, g)?;
    if g.teeth != teeth {
        return Err(v.err(&format!("{field}.teeth"), format!("{} teeth, the machine file says {teeth}", g.teeth)));
    }
    let errors = v.errors(&format!("{field}.errors"), &g.errors)?;
    let faults = v.tooth_faults(&format!("{field}.tooth_faults"), teeth, &g.tooth_faults, tolerance, notes)?;
    Ok(TrainGear {
        teeth,
        inertia_kg_m2: g.inertia_kg_m2,
        base_radius_m: g.base_radius_m,
        errors: errors.plus(&faults),
    })
}

fn mesh(v: &Validator<'_>, f: &str, m: &RawMesh) -> Result<FourierSeries, SceneError> {
    let RawMesh::Fourier { mean_n_per_m, harmonics } = m else {
        return Err(v.err(
            f,
            "a gear_train takes a `fourier` mesh stiffness (harmonic balance needs smooth coefficients)".into(),
        ));
    };
    let mean = v.positive(&format!("{f}.fourier.mean_n_per_m"), *mean_n_per_m)?;
    let mut terms = Vec::with_capacity(harmonics.len());
    let mut sum = 0.0;
    for (i, h) in harmonics.iter().enumerate() {
        let a = v.non_negative(&format!("{f}.fourier.harmonics[{i}].amplitude_n_per_m"), h.amplitude_n_per_m)?;
        v.finite(&format!("{f}.fourier.harmonics[{i}].phase_rad"), h.phase_rad)?;
        sum += a;
        terms.push((i + 1, a, h.phase_rad));
    }
    if sum >= mean {
        return Err(v.err(
            &format!("{f}.fourier.harmonics"),
            format!("harmonic amplitudes add up to {sum:e} N/m, not below the mean {mean:e}: the stiffness could turn negative"),
        ));
    }
    Ok(FourierSeries::from_amplitude_phase(1.0, mean, &terms))
}
