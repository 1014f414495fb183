//! Kinematics of a gearbox: shafts, parallel and planetary stages, exact speed ratios, mesh frequencies and
//! the characteristic fault orders. Everything is an exact rational [`Ratio`] relative to one reference
//! shaft (the shaft whose speed is given or tracked), so every shaft's angle follows the tracked one without
//! drift (an f64 ratio would drift by N eps over N revolutions).
//!
//! ```text
//! parallel stage a -> b (external mesh, teeth z_a on a, z_b on b):
//!     w_b = -w_a z_a / z_b              mesh order = z_a |w_a| = z_b |w_b|
//! planetary stage (sun s, carrier c, ring r; one member fixed; z_r = z_s + 2 z_p), Willis:
//!     z_s w_s + z_r w_r = (z_s + z_r) w_c
//!     w_p - w_c = -(z_s / z_p) (w_s - w_c)            (planet, absolute and relative to the carrier)
//!     mesh = z_s |w_s - w_c| = z_r |w_r - w_c| = z_p |w_p - w_c|
//!     planet pass (housing-fixed sensor) = N_p |w_c|
//!     sun fault = N_p |w_s - w_c|,  ring fault = N_p |w_r - w_c|,
//!     planet fault = |w_p - w_c| (one flank: ring or sun side), 2 |w_p - w_c| (both flanks)
//! ```
//! Speeds are signed (a parallel mesh reverses the sense of rotation); frequencies are their magnitudes.
//! Planets are numbered in the order they pass the sensor: planet 1 is at the sensor when the carrier's
//! tachometer pulses, planet i passes it `planet_angles_deg[i-1]` degrees of carrier rotation later (equal
//! spacing 360 (i-1) / N_p by default).

mod lines;
mod ratio;
pub use lines::{Line, LineKind};
pub use ratio::Ratio;
use ratio::gcd_i;

/// A planetary member: held fixed (to the housing) or turning with a shaft.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Member {
    /// Held by the housing.
    Fixed,
    /// Turns with the shaft of this index in [`Machine::shafts`].
    Shaft(usize),
}

/// A parallel (external) gear pair: the driving gear on one shaft meshes with the driven gear on another.
#[derive(Clone, Debug, PartialEq)]
pub struct ParallelStage {
    /// Index of the driving shaft.
    pub driving: usize,
    /// Index of the driven shaft.
    pub driven: usize,
    /// Teeth of the driving gear.
    pub driving_teeth: u32,
    /// Teeth of the driven gear.
    pub driven_teeth: u32,
}

/// A planetary stage: sun, N_p planets on a carrier, ring; one member fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanetaryStage {
    /// The sun.
    pub sun: Member,
    /// The carrier.
    pub carrier: Member,
    /// The ring (annulus).
    pub ring: Member,
    /// Number of planets N_p.
    pub planets: u32,
    /// Sun teeth z_s.
    pub sun_teeth: u32,
    /// Teeth of each planet z_p.
    pub planet_teeth: u32,
    /// Ring teeth z_r (= z_s + 2 z_p).
    pub ring_teeth: u32,
    /// Carrier angle, degrees, at which planet i (index i - 1) passes the sensor after planet 1; first 0.
    pub planet_angles_deg: Vec<f64>,
}

/// A gear stage.
#[derive(Clone, Debug, PartialEq)]
pub enum Stage {
    /// A parallel pair.
    Parallel(ParallelStage),
    /// A planetary stage.
    Planetary(PlanetaryStage),
}

/// The nominal speed of one shaft.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedSpec {
    /// Index of the shaft.
    pub shaft: usize,
    /// Nominal speed, rev/min.
    pub nominal_rpm: f64,
    /// Relative tolerance of the nominal speed (0.05 = 5 %).
    pub tolerance: f64,
}

/// A tachometer channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Tachometer {
    /// Channel, 1-based.
    pub channel: u32,
    /// Index of the shaft it watches.
    pub shaft: usize,
    /// Pulses per revolution of that shaft.
    pub pulses_per_rev: u32,
}

/// Physical unit of a vibration sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
pub enum SensorUnit {
    /// Acceleration, m/s^2.
    #[serde(rename = "m/s^2")]
    MetrePerSecondSquared,
    /// Acceleration, standard gravity (9.80665 m/s^2).
    #[serde(rename = "g")]
    G,
    /// Velocity, m/s.
    #[serde(rename = "m/s")]
    MetrePerSecond,
    /// Velocity, mm/s.
    #[serde(rename = "mm/s")]
    MillimetrePerSecond,
    /// Displacement, m.
    #[serde(rename = "m")]
    Metre,
    /// Displacement, micrometres.
    #[serde(rename = "um")]
    Micrometre,
    /// Raw sensor voltage, V.
    #[serde(rename = "V")]
    Volt,
}

impl SensorUnit {
    /// The unit's name as machine files, sidecars and `--unit` write it (`m/s^2`, `g`, `m/s`, `mm/s`, `m`,
    /// `um`, `V`).
    pub fn name(self) -> &'static str {
        match self {
            SensorUnit::MetrePerSecondSquared => "m/s^2",
            SensorUnit::G => "g",
            SensorUnit::MetrePerSecond => "m/s",
            SensorUnit::MillimetrePerSecond => "mm/s",
            SensorUnit::Metre => "m",
            SensorUnit::Micrometre => "um",
            SensorUnit::Volt => "V",
        }
    }
}

/// A vibration sensor channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    /// Channel, 1-based.
    pub channel: u32,
    /// Where it sits ("output bearing, radial").
    pub position: String,
    /// Unit of the recorded values after dividing by `sensitivity`.
    pub unit: SensorUnit,
    /// Recorded value per unit of the physical quantity (1.0 when the file holds physical units).
    pub sensitivity: f64,
}

/// Why the stages do not give every shaft one speed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    /// Two paths through the stages give one shaft two different speeds.
    #[error(
        "the ratios do not close: this stage gives shaft `{shaft}` the speed {second} times the reference shaft's, the stages before it {first}"
    )]
    NotClosed {
        /// 0-based stage index.
        stage: usize,
        /// Shaft name.
        shaft: String,
        /// Ratio from the earlier path.
        first: Ratio,
        /// Ratio from this stage.
        second: Ratio,
    },
    /// No stage connects a shaft to the reference shaft.
    #[error("shaft `{shaft}` is not connected to the reference shaft `{reference}` by any stage: its speed is unknown")]
    Unreached {
        /// 0-based shaft index.
        index: usize,
        /// Shaft name.
        shaft: String,
        /// Reference shaft name.
        reference: String,
    },
    /// The exact ratio chain overflows 128-bit integers.
    #[error("the exact speed ratio overflows 128-bit integers at this stage (too many stages or teeth)")]
    Overflow {
        /// 0-based stage index.
        stage: usize,
    },
}

/// A validated gearbox: shafts, stages, and the exact order (speed relative to the reference shaft) of
/// every shaft.
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    /// Name.
    pub name: String,
    /// Shaft names.
    pub shafts: Vec<String>,
    /// Stages, in file order.
    pub stages: Vec<Stage>,
    /// Nominal speed, if given.
    pub speed: Option<SpeedSpec>,
    /// Tachometer, if given.
    pub tachometer: Option<Tachometer>,
    /// Vibration sensors.
    pub sensors: Vec<Sensor>,
    reference: usize,
    orders: Vec<Ratio>,
}

/// Exact orders of a planetary stage, relative to the machine's reference shaft (signed speeds; the fault
/// and pass orders are magnitudes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanetaryOrders {
    /// Sun speed (0 when fixed).
    pub sun: Ratio,
    /// Carrier speed.
    pub carrier: Ratio,
    /// Ring speed.
    pub ring: Ratio,
    /// Planet speed, absolute.
    pub planet: Ratio,
    /// Planet speed relative to the carrier.
    pub planet_relative: Ratio,
    /// Mesh order z_s |w_s - w_c|.
    pub mesh: Ratio,
    /// Planet-pass order N_p |w_c| (sensor fixed to the housing).
    pub planet_pass: Ratio,
    /// Local sun-tooth fault order N_p |w_s - w_c|.
    pub sun_fault: Ratio,
    /// Local planet-tooth fault order, one flank: |w_p - w_c|.
    pub planet_fault: Ratio,
    /// Local planet-tooth fault order, both flanks: 2 |w_p - w_c|.
    pub planet_fault_both: Ratio,
    /// Local ring-tooth fault order N_p |w_r - w_c|.
    pub ring_fault: Ratio,
}

/// One stage's speed relation: w_to = q w_from.
fn relation(stage: &Stage) -> Option<(usize, usize, Ratio)> {
    match stage {
        Stage::Parallel(p) => {
            Some((p.driving, p.driven, Ratio::new(-(p.driving_teeth as i128), p.driven_teeth as i128)?))
        }
        Stage::Planetary(p) => {
            let (zs, zr) = (p.sun_teeth as i128, p.ring_teeth as i128);
            // Willis with the fixed member's speed 0
            match (p.sun, p.carrier, p.ring) {
                (Member::Shaft(s), Member::Shaft(c), Member::Fixed) => Some((s, c, Ratio::new(zs, zs + zr)?)),
                (Member::Fixed, Member::Shaft(c), Member::Shaft(r)) => Some((r, c, Ratio::new(zr, zs + zr)?)),
                (Member::Shaft(s), Member::Fixed, Member::Shaft(r)) => Some((s, r, Ratio::new(-zs, zr)?)),
                _ => None,
            }
        }
    }
}

impl Machine {
    /// Builds the machine and every shaft's exact order from the ratio chain, relative to `reference` (the
    /// shaft whose speed is given or tracked). The stages must already be checked one by one (teeth >= 1,
    /// shaft indices in range, exactly one fixed planetary member, z_r = z_s + 2 z_p).
    ///
    /// # Errors
    /// [`KinematicsError`]: ratios that do not close around a loop of stages, a shaft no stage reaches, an
    /// overflow of the exact arithmetic.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: String,
        shafts: Vec<String>,
        stages: Vec<Stage>,
        reference: usize,
        speed: Option<SpeedSpec>,
        tachometer: Option<Tachometer>,
        sensors: Vec<Sensor>,
    ) -> Result<Self, KinematicsError> {
        let mut orders: Vec<Option<Ratio>> = vec![None; shafts.len()];
        orders[reference] = Some(Ratio::ONE);
        let relations: Vec<_> = stages.iter().map(relation).collect();
        // propagate until nothing changes; a stage whose both shafts are known checks the loop closes
        let mut done = vec![false; stages.len()];
        loop {
            let mut progress = false;
            for (k, rel) in relations.iter().enumerate() {
                let Some((a, b, q)) = *rel else { continue };
                if done[k] {
                    continue;
                }
                let (other, value) = match (orders[a], orders[b]) {
                    (Some(ra), _) => (b, ra.checked_mul(q)),
                    (None, Some(rb)) => (a, rb.checked_div(q)),
                    (None, None) => continue,
                };
                let value = value.ok_or(KinematicsError::Overflow { stage: k })?;
                match orders[other] {
                    Some(first) if first != value => {
                        return Err(KinematicsError::NotClosed {
                            stage: k,
                            shaft: shafts[other].clone(),
                            first,
                            second: value,
                        });
                    }
                    _ => orders[other] = Some(value),
                }
                done[k] = true;
                progress = true;
            }
            if !progress {
                break;
            }
        }
        let orders = orders
            .iter()
            .enumerate()
            .map(|(i, o)| {
                o.ok_or_else(|| KinematicsError::Unreached {
                    index: i,
                    shaft: shafts[i].clone(),
                    reference: shafts[reference].clone(),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let machine = Self { name, shafts, stages, speed, tachometer, sensors, reference, orders };
        for k in 0..machine.stages.len() {
            if let Stage::Planetary(_) = machine.stages[k] {
                machine.planetary_orders(k).ok_or(KinematicsError::Overflow { stage: k })?;
            }
            machine.mesh_order(k).ok_or(KinematicsError::Overflow { stage: k })?;
        }
        Ok(machine)
    }

    /// Index of the reference shaft (orders are relative to its speed).
    pub fn reference(&self) -> usize {
        self.reference
    }

    /// Index of the shaft named `name`.
    pub fn shaft_index(&self, name: &str) -> Option<usize> {
        self.shafts.iter().position(|s| s == name)
    }

    /// Signed speed of shaft `i` relative to the reference shaft (exact).
    pub fn order(&self, i: usize) -> Ratio {
        self.orders[i]
    }

    /// Signed speed of shaft `i` relative to shaft `j` (exact).
    pub fn ratio(&self, i: usize, j: usize) -> Ratio {
        // both orders are finite and the reference is reached, so j's order is non-zero
        self.orders[i].checked_div(self.orders[j]).unwrap_or(Ratio::ZERO)
    }

    /// Rotation frequency of every shaft, Hz, given shaft `shaft` turns at `hz` Hz (magnitudes).
    pub fn speeds_hz(&self, shaft: usize, hz: f64) -> Vec<f64> {
        (0..self.shafts.len()).map(|i| (self.ratio(i, shaft).to_f64() * hz).abs()).collect()
    }

    fn member_order(&self, m: Member) -> Ratio {
        match m {
            Member::Fixed => Ratio::ZERO,
            Member::Shaft(i) => self.orders[i],
        }
    }

    /// Mesh order of stage `k` (mesh frequency over the reference shaft's frequency); `None` on overflow.
    pub fn mesh_order(&self, k: usize) -> Option<Ratio> {
        match &self.stages[k] {
            Stage::Parallel(p) => {
                self.orders[p.driving].checked_mul(Ratio::integer(p.driving_teeth as i128)).map(Ratio::abs)
            }
            Stage::Planetary(_) => self.planetary_orders(k).map(|o| o.mesh),
        }
    }

    /// Mesh frequency of every stage, Hz, given the reference shaft turns at `hz` Hz.
    pub fn mesh_hz(&self, hz: f64) -> Vec<f64> {
        (0..self.stages.len()).map(|k| self.mesh_order(k).map_or(f64::NAN, |o| o.to_f64() * hz.abs())).collect()
    }

    /// Hunting-tooth order of parallel stage `k`: mesh / lcm(z_a, z_b) (a tooth pair meets again after
    /// z_b / gcd revolutions of the driving shaft); `None` for a planetary stage.
    pub fn hunting_order(&self, k: usize) -> Option<Ratio> {
        let Stage::Parallel(p) = &self.stages[k] else { return None };
        let (a, b) = (p.driving_teeth as i128, p.driven_teeth as i128);
        let lcm = a / gcd_i(a, b) * b;
        self.mesh_order(k)?.checked_div(Ratio::integer(lcm))
    }

    /// Exact orders of planetary stage `k` (`None` for a parallel stage or on overflow).
    pub fn planetary_orders(&self, k: usize) -> Option<PlanetaryOrders> {
        let Stage::Planetary(p) = &self.stages[k] else { return None };
        let (s, c, r) = (self.member_order(p.sun), self.member_order(p.carrier), self.member_order(p.ring));
        let zs = Ratio::integer(p.sun_teeth as i128);
        let zp = Ratio::integer(p.planet_teeth as i128);
        let np = Ratio::integer(p.planets as i128);
        let sun_rel = s.checked_sub(c)?;
        let planet_relative = sun_rel.checked_mul(zs)?.checked_div(zp)?.checked_mul(Ratio::integer(-1))?;
        let mesh = sun_rel.checked_mul(zs)?.abs();
        Some(PlanetaryOrders {
            sun: s,
            carrier: c,
            ring: r,
            planet: c.checked_add(planet_relative)?,
            planet_relative,
            mesh,
            planet_pass: c.checked_mul(np)?.abs(),
            sun_fault: sun_rel.checked_mul(np)?.abs(),
            planet_fault: planet_relative.abs(),
            planet_fault_both: planet_relative.checked_mul(Ratio::integer(2))?.abs(),
            ring_fault: r.checked_sub(c)?.checked_mul(np)?.abs(),
        })
    }
}

/// Carrier angles (degrees) of N_p equally spaced planets: 360 (i - 1) / N_p.
pub fn equal_planet_angles_deg(planets: u32) -> Vec<f64> {
    (0..planets).map(|i| 360.0 * i as f64 / planets as f64).collect()
}
