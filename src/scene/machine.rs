//! Machine files (DESIGN.md section 4): the gearbox's shafts, parallel and planetary stages, the shaft whose
//! speed is given or tracked, the tachometer and the sensors. Read with serde (`deny_unknown_fields`, every
//! parse error naming the field path), then validated field by field into a
//! [`Machine`] whose exact ratio chain must close.
//!
//! ```json
//! {"machine": "two-stage example", "shafts": ["input", "intermediate", "output"],
//!  "stages": [{"kind": "parallel", "driving": "input", "driven": "intermediate", "teeth": [23, 61]},
//!             {"kind": "planetary", "sun": "intermediate", "carrier": "output", "ring": "fixed",
//!              "planets": 3, "teeth": {"sun": 21, "planet": 31, "ring": 83}}],
//!  "speed": {"shaft": "input", "nominal_rpm": 1480, "tolerance": 0.05},
//!  "tachometer": {"channel": 2, "shaft": "input", "pulses_per_rev": 1},
//!  "sensors": [{"channel": 1, "position": "output bearing, radial", "unit": "m/s^2", "sensitivity": 1.0}]}
//! ```

use super::SceneError;
use crate::model::kinematics::{
    KinematicsError, Machine, Member, ParallelStage, PlanetaryStage, Sensor, SensorUnit, SpeedSpec, Stage, Tachometer,
    equal_planet_angles_deg,
};
use serde::Deserialize;

/// Most shafts of a machine file.
const MAX_SHAFTS: usize = 32;
/// Most stages of a machine file (the exact ratio chain stays within 128-bit integers).
const MAX_STAGES: usize = 8;
/// Teeth of one gear: at least 3, at most this.
const MAX_TEETH: u32 = 10_000;
/// Most planets of a planetary stage.
const MAX_PLANETS: u32 = 32;
/// Highest channel number.
const MAX_CHANNEL: u32 = 4096;
/// A planet angle must put a whole number of (z_s + z_r) pitches between planets within this many pitches.
const ASSEMBLY_TOLERANCE_PITCH: f64 = 1e-6;

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
enum StageKind {
    Parallel,
    Planetary,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawMachine {
    machine: String,
    /// Free text for people; accepted, not used.
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    shafts: Vec<String>,
    stages: Vec<RawStage>,
    #[serde(default)]
    speed: Option<RawSpeed>,
    #[serde(default)]
    tachometer: Option<RawTachometer>,
    #[serde(default)]
    sensors: Vec<RawSensor>,
}

/// One stage with the fields of both kinds (the kind decides which are allowed): a flat struct keeps
/// serde_path_to_error's path down to the field, which an internally tagged enum would lose.
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawStage {
    kind: StageKind,
    #[serde(default)]
    driving: Option<String>,
    #[serde(default)]
    driven: Option<String>,
    teeth: serde_json::Value,
    #[serde(default)]
    sun: Option<String>,
    #[serde(default)]
    carrier: Option<String>,
    #[serde(default)]
    ring: Option<String>,
    #[serde(default)]
    planets: Option<u32>,
    #[serde(default)]
    planet_angles_deg: Option<Vec<f64>>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct PlanetaryTeeth {
    sun: u32,
    planet: u32,
    ring: u32,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawSpeed {
    shaft: String,
    nominal_rpm: f64,
    #[serde(default)]
    tolerance: Option<f64>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawTachometer {
    channel: u32,
    shaft: String,
    #[serde(default = "one")]
    pulses_per_rev: u32,
}

fn one() -> u32 {
    1
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct RawSensor {
    channel: u32,
    position: String,
    unit: SensorUnit,
    #[serde(default = "unit_sensitivity")]
    sensitivity: f64,
}

fn unit_sensitivity() -> f64 {
    1.0
}

/// Default relative tolerance of a nominal speed.
const DEFAULT_SPEED_TOLERANCE: f64 = 0.05;

/// Reads and validates a machine file.
///
/// # Errors
/// [`SceneError`] naming the file and the field path.
pub fn load_machine(path: &str) -> Result<Machine, SceneError> {
    crate::io::register_input(std::path::Path::new(path));
    let text =
        std::fs::read_to_string(path).map_err(|e| SceneError::Io { file: path.to_string(), message: e.to_string() })?;
    machine_from_str(&text, path)
}

/// Validates a machine file given as text (`file` is used in messages).
///
/// # Errors
/// [`SceneError`] naming the file and the field path.
pub fn machine_from_str(text: &str, file: &str) -> Result<Machine, SceneError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let raw: RawMachine = serde_path_to_error::deserialize(&mut de).map_err(|e| super::json_error(file, e))?;
    de.end().map_err(|e| SceneError::Json { file: file.to_string(), message: e.to_string() })?;
    MachineValidator { file }.machine(&raw)
}

/// Validates a machine given as JSON (a machine object inside another file; `prefix` is its field path
/// there, e.g. "machine").
///
/// # Errors
/// [`SceneError`] naming the file and the field path.
pub fn machine_from_value(value: serde_json::Value, file: &str, prefix: &str) -> Result<Machine, SceneError> {
    let raw: RawMachine = serde_path_to_error::deserialize(value).map_err(|e| {
        let path = join(prefix, &e.path().to_string());
        SceneError::Json { file: file.to_string(), message: format!("field `{path}`: {}", e.into_inner()) }
    })?;
    let v = MachineValidator { file };
    v.machine(&raw).map_err(|e| match e {
        SceneError::Invalid { file, field, message } => {
            SceneError::Invalid { file, field: join(prefix, &field), message }
        }
        other => other,
    })
}

/// A validated machine together with the JSON it was read from: what a profile stores (the machine file's
/// own text, so that people can read it) and validates again when it is read back.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineFile {
    json: serde_json::Value,
    machine: Machine,
}

impl MachineFile {
    /// The validated machine.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }
}

/// Reads and validates a machine file, keeping its JSON.
///
/// # Errors
/// [`SceneError`] naming the file and the field path.
pub fn load_machine_file(path: &str) -> Result<MachineFile, SceneError> {
    crate::io::register_input(std::path::Path::new(path));
    let text =
        std::fs::read_to_string(path).map_err(|e| SceneError::Io { file: path.to_string(), message: e.to_string() })?;
    let machine = machine_from_str(&text, path)?;
    let json =
        serde_json::from_str(&text).map_err(|e| SceneError::Json { file: path.into(), message: e.to_string() })?;
    Ok(MachineFile { json, machine })
}

impl serde::Serialize for MachineFile {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.json.serialize(s)
    }
}

impl<'de> Deserialize<'de> for MachineFile {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let json = serde_json::Value::deserialize(d)?;
        let machine = machine_from_value(json.clone(), "the machine", "")
            .map_err(|e| serde::de::Error::custom(e.to_string().trim_start_matches("the machine: ").to_string()))?;
        Ok(Self { json, machine })
    }
}

/// `prefix` + `path` as one dotted field path ("stages[0].teeth" + "[1]", "stages[0].teeth" + "ring").
fn join(prefix: &str, path: &str) -> String {
    if prefix.is_empty() || path == "." || path.is_empty() {
        return if prefix.is_empty() { path.to_string() } else { prefix.to_string() };
    }
    if path.starts_with('[') { format!("{prefix}{path}") } else { format!("{prefix}.{path}") }
}

struct MachineValidator<'a> {
    file: &'a str,
}

impl MachineValidator<'_> {
    fn err(&self, field: &str, message: String) -> SceneError {
        SceneError::Invalid { file: self.file.to_string(), field: field.to_string(), message }
    }

    fn shaft(&self, shafts: &[String], field: &str, name: &str) -> Result<usize, SceneError> {
        shafts
            .iter()
            .position(|s| s == name)
            .ok_or_else(|| self.err(field, format!("\"{name}\" is not one of the shafts ({})", shafts.join(", "))))
    }

    fn teeth(&self, field: &str, z: u32) -> Result<u32, SceneError> {
        if (3..=MAX_TEETH).contains(&z) {
            Ok(z)
        } else {
            Err(self.err(field, format!("must be an integer in 3..={MAX_TEETH}, got {z}")))
        }
    }

    fn machine(&self, raw: &RawMachine) -> Result<Machine, SceneError> {
        let shafts = self.shafts(&raw.shafts)?;
        if raw.stages.is_empty() || raw.stages.len() > MAX_STAGES {
            return Err(self.err("stages", format!("must have 1..={MAX_STAGES} stages, got {}", raw.stages.len())));
        }
        let stages =
            raw.stages.iter().enumerate().map(|(k, s)| self.stage(&shafts, k, s)).collect::<Result<Vec<_>, _>>()?;
        let speed = raw.speed.as_ref().map(|s| self.speed(&shafts, s)).transpose()?;
        let tachometer = raw.tachometer.as_ref().map(|t| self.tachometer(&shafts, t)).transpose()?;
        let sensors = self.sensors(&raw.sensors, tachometer.as_ref())?;
        let reference = speed.as_ref().map(|s| s.shaft).or(tachometer.as_ref().map(|t| t.shaft)).unwrap_or(0);
        Machine::new(raw.machine.clone(), shafts, stages, reference, speed, tachometer, sensors).map_err(|e| {
            let field = match &e {
                KinematicsError::NotClosed { stage, .. } => format!("stages[{stage}]"),
                KinematicsError::Unreached { index, .. } => format!("shafts[{index}]"),
                KinematicsError::Overflow { stage } => format!("stages[{stage}].teeth"),
            };
            self.err(&field, e.to_string())
        })
    }

    fn shafts(&self, raw: &[String]) -> Result<Vec<String>, SceneError> {
        if raw.is_empty() || raw.len() > MAX_SHAFTS {
            return Err(self.err("shafts", format!("must name 1..={MAX_SHAFTS} shafts, got {}", raw.len())));
        }
        for (i, s) in raw.iter().enumerate() {
            if s.trim().is_empty() {
                return Err(self.err(&format!("shafts[{i}]"), "a shaft name must not be empty".into()));
            }
            if s == "fixed" {
                return Err(self.err(
                    &format!("shafts[{i}]"),
                    "\"fixed\" names the housing in planetary stages; choose another shaft name".into(),
                ));
            }
            if raw[..i].contains(s) {
                return Err(self.err(&format!("shafts[{i}]"), format!("\"{s}\" is named twice")));
            }
        }
        Ok(raw.to_vec())
    }

    /// Fields that belong to the other kind of stage are refused by name.
    fn foreign(&self, f: &str, s: &RawStage) -> Result<(), SceneError> {
        let (kind, fields): (&str, Vec<(&str, bool)>) = match s.kind {
            StageKind::Parallel => (
                "parallel",
                vec![
                    ("sun", s.sun.is_some()),
                    ("carrier", s.carrier.is_some()),
                    ("ring", s.ring.is_some()),
                    ("planets", s.planets.is_some()),
                    ("planet_angles_deg", s.planet_angles_deg.is_some()),
                ],
            ),
            StageKind::Planetary => {
                ("planetary", vec![("driving", s.driving.is_some()), ("driven", s.driven.is_some())])
            }
        };
        match fields.iter().find(|(_, given)| *given) {
            Some((name, _)) => Err(self.err(&format!("{f}.{name}"), format!("not a field of a {kind} stage"))),
            None => Ok(()),
        }
    }

    fn stage(&self, shafts: &[String], k: usize, s: &RawStage) -> Result<Stage, SceneError> {
        let f = format!("stages[{k}]");
        self.foreign(&f, s)?;
        match s.kind {
            StageKind::Parallel => self.parallel(shafts, &f, s).map(Stage::Parallel),
            StageKind::Planetary => self.planetary(shafts, &f, s).map(Stage::Planetary),
        }
    }

    fn required<'b>(&self, field: &str, v: &'b Option<String>, kind: &str) -> Result<&'b str, SceneError> {
        v.as_deref().ok_or_else(|| self.err(field, format!("missing: a {kind} stage needs it")))
    }

    fn typed<T: serde::de::DeserializeOwned>(&self, field: &str, v: &serde_json::Value) -> Result<T, SceneError> {
        serde_path_to_error::deserialize(v.clone()).map_err(|e| {
            let path = join(field, &e.path().to_string());
            SceneError::Json { file: self.file.to_string(), message: format!("field `{path}`: {}", e.into_inner()) }
        })
    }

    fn parallel(&self, shafts: &[String], f: &str, s: &RawStage) -> Result<ParallelStage, SceneError> {
        let driving = self.required(&format!("{f}.driving"), &s.driving, "parallel")?;
        let driven = self.required(&format!("{f}.driven"), &s.driven, "parallel")?;
        let a = self.shaft(shafts, &format!("{f}.driving"), driving)?;
        let b = self.shaft(shafts, &format!("{f}.driven"), driven)?;
        if a == b {
            return Err(self.err(&format!("{f}.driven"), format!("is the driving shaft \"{driving}\" too")));
        }
        let teeth: [u32; 2] = self.typed(&format!("{f}.teeth"), &s.teeth)?;
        Ok(ParallelStage {
            driving: a,
            driven: b,
            driving_teeth: self.teeth(&format!("{f}.teeth[0]"), teeth[0])?,
            driven_teeth: self.teeth(&format!("{f}.teeth[1]"), teeth[1])?,
        })
    }

    fn member(&self, shafts: &[String], field: &str, v: &Option<String>) -> Result<Member, SceneError> {
        match self.required(field, v, "planetary")? {
            "fixed" => Ok(Member::Fixed),
            name => self.shaft(shafts, field, name).map(Member::Shaft),
        }
    }

    fn planetary(&self, shafts: &[String], f: &str, s: &RawStage) -> Result<PlanetaryStage, SceneError> {
        let sun = self.member(shafts, &format!("{f}.sun"), &s.sun)?;
        let carrier = self.member(shafts, &format!("{f}.carrier"), &s.carrier)?;
        let ring = self.member(shafts, &format!("{f}.ring"), &s.ring)?;
        let members = [("sun", sun), ("carrier", carrier), ("ring", ring)];
        let fixed = members.iter().filter(|(_, m)| *m == Member::Fixed).count();
        if fixed != 1 {
            // two fixed: name the one that is not the ring (a fixed ring is the usual stage), none: the ring
            let field = members.iter().find(|(_, m)| *m == Member::Fixed).map_or("ring", |(n, _)| n);
            let why = if fixed == 0 {
                "no member is \"fixed\": a stage with all three members turning is a differential, whose speeds one shaft's speed cannot fix"
            } else {
                "two members are \"fixed\": the stage could not turn"
            };
            return Err(self
                .err(&format!("{f}.{field}"), format!("{why}; exactly one of sun, carrier, ring must be \"fixed\"")));
        }
        let moving: Vec<(&str, usize)> =
            members.iter().filter_map(|(n, m)| if let Member::Shaft(i) = m { Some((*n, *i)) } else { None }).collect();
        if moving[0].1 == moving[1].1 {
            return Err(self.err(
                &format!("{f}.{}", moving[1].0),
                format!("is on the same shaft as the {}: the stage would be locked", moving[0].0),
            ));
        }
        let planets =
            s.planets.ok_or_else(|| self.err(&format!("{f}.planets"), "missing: a planetary stage needs it".into()))?;
        if !(1..=MAX_PLANETS).contains(&planets) {
            return Err(self.err(&format!("{f}.planets"), format!("must be in 1..={MAX_PLANETS}, got {planets}")));
        }
        let t: PlanetaryTeeth = self.typed(&format!("{f}.teeth"), &s.teeth)?;
        let zs = self.teeth(&format!("{f}.teeth.sun"), t.sun)?;
        let zp = self.teeth(&format!("{f}.teeth.planet"), t.planet)?;
        let zr = self.teeth(&format!("{f}.teeth.ring"), t.ring)?;
        if zr != zs + 2 * zp {
            return Err(self.err(
                &format!("{f}.teeth.ring"),
                format!(
                    "{zr} teeth do not fit sun {zs} + 2 x planet {zp} = {} (unshifted gears: ring = sun + 2 planet)",
                    zs + 2 * zp
                ),
            ));
        }
        let planet_angles_deg = self.planet_angles(f, s.planet_angles_deg.as_deref(), planets, zs + zr)?;
        Ok(PlanetaryStage {
            sun,
            carrier,
            ring,
            planets,
            sun_teeth: zs,
            planet_teeth: zp,
            ring_teeth: zr,
            planet_angles_deg,
        })
    }

    /// Planet positions: equal spacing by default (needs (z_s + z_r) / N_p whole); given angles start at 0,
    /// increase below 360, and each must let the planet mesh with sun and ring at once: (z_s + z_r) psi / 360
    /// whole.
    fn planet_angles(&self, f: &str, given: Option<&[f64]>, planets: u32, sum: u32) -> Result<Vec<f64>, SceneError> {
        let field = format!("{f}.planet_angles_deg");
        let Some(angles) = given else {
            if !sum.is_multiple_of(planets) {
                return Err(self.err(
                    &field,
                    format!("required: (sun + ring teeth) / planets = {sum}/{planets} is not whole, so the planets cannot be equally spaced"),
                ));
            }
            return Ok(equal_planet_angles_deg(planets));
        };
        if angles.len() != planets as usize {
            return Err(self.err(&field, format!("has {} angles, expected one per planet ({planets})", angles.len())));
        }
        for (i, &a) in angles.iter().enumerate() {
            let fi = format!("{field}[{i}]");
            if i == 0 && a != 0.0 {
                return Err(
                    self.err(&fi, format!("must be 0 (planet 1 is at the sensor at the tachometer pulse), got {a}"))
                );
            }
            if !(a.is_finite() && (0.0..360.0).contains(&a)) || (i > 0 && a <= angles[i - 1]) {
                return Err(self.err(&fi, format!("must increase strictly within [0, 360), got {a}")));
            }
            let pitches = sum as f64 * a / 360.0;
            if (pitches - pitches.round()).abs() > ASSEMBLY_TOLERANCE_PITCH {
                return Err(self.err(
                    &fi,
                    format!(
                        "{a} degrees cannot be assembled: (sun + ring teeth) x angle / 360 = {pitches:.4} must be whole"
                    ),
                ));
            }
        }
        Ok(angles.to_vec())
    }

    fn speed(&self, shafts: &[String], s: &RawSpeed) -> Result<SpeedSpec, SceneError> {
        let shaft = self.shaft(shafts, "speed.shaft", &s.shaft)?;
        if !(s.nominal_rpm.is_finite() && s.nominal_rpm > 0.0) {
            return Err(self.err("speed.nominal_rpm", format!("must be a positive number, got {}", s.nominal_rpm)));
        }
        let tolerance = s.tolerance.unwrap_or(DEFAULT_SPEED_TOLERANCE);
        if !(tolerance.is_finite() && (0.0..1.0).contains(&tolerance)) {
            return Err(self.err("speed.tolerance", format!("must be a relative tolerance in [0, 1), got {tolerance}")));
        }
        Ok(SpeedSpec { shaft, nominal_rpm: s.nominal_rpm, tolerance })
    }

    fn channel(&self, field: &str, c: u32) -> Result<u32, SceneError> {
        if (1..=MAX_CHANNEL).contains(&c) {
            Ok(c)
        } else {
            Err(self.err(field, format!("must be a 1-based channel number in 1..={MAX_CHANNEL}, got {c}")))
        }
    }

    fn tachometer(&self, shafts: &[String], t: &RawTachometer) -> Result<Tachometer, SceneError> {
        let channel = self.channel("tachometer.channel", t.channel)?;
        let shaft = self.shaft(shafts, "tachometer.shaft", &t.shaft)?;
        if !(1..=100_000).contains(&t.pulses_per_rev) {
            return Err(
                self.err("tachometer.pulses_per_rev", format!("must be in 1..=100000, got {}", t.pulses_per_rev))
            );
        }
        Ok(Tachometer { channel, shaft, pulses_per_rev: t.pulses_per_rev })
    }

    fn sensors(&self, raw: &[RawSensor], tacho: Option<&Tachometer>) -> Result<Vec<Sensor>, SceneError> {
        let mut out: Vec<Sensor> = Vec::with_capacity(raw.len());
        for (i, s) in raw.iter().enumerate() {
            let f = format!("sensors[{i}]");
            let channel = self.channel(&format!("{f}.channel"), s.channel)?;
            if tacho.is_some_and(|t| t.channel == channel) {
                return Err(self.err(&format!("{f}.channel"), format!("channel {channel} is the tachometer's")));
            }
            if out.iter().any(|o| o.channel == channel) {
                return Err(self.err(&format!("{f}.channel"), format!("channel {channel} is given twice")));
            }
            if !(s.sensitivity.is_finite() && s.sensitivity > 0.0) {
                return Err(
                    self.err(&format!("{f}.sensitivity"), format!("must be a positive number, got {}", s.sensitivity))
                );
            }
            out.push(Sensor { channel, position: s.position.clone(), unit: s.unit, sensitivity: s.sensitivity });
        }
        Ok(out)
    }
}
