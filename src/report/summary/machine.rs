//! The machine part of a diagnosis (`diagnose --machine`): every stage's mesh harmonics with their sideband
//! families labelled by the shaft that makes them, a planetary stage's characteristic orders and the
//! per-planet averages.

use super::VerdictGear;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What a machine diagnosis adds to the pair's keys.
#[derive(Clone, Debug, Serialize)]
pub struct MachineDiagnosis {
    /// The machine file's `machine` name.
    pub machine: String,
    /// The shaft whose angle was tracked (orders below are of this shaft's rotation).
    pub tracked_shaft: String,
    /// One entry per stage, in the machine file's order.
    pub stages: Vec<StageDiagnosis>,
}

/// One stage's lines on the deciding channel.
#[derive(Clone, Debug, Serialize)]
pub struct StageDiagnosis {
    /// Stage, 1-based.
    pub stage: usize,
    /// `parallel` or `planetary`.
    pub kind: StageKind,
    /// The gears of the stage: what they are, their shaft (`null` for a fixed ring or the planets) and teeth.
    pub gears: Vec<StageGear>,
    /// Mesh order (mesh frequency over the tracked shaft's rotation frequency), exact as `num/den`.
    pub mesh_order_exact: String,
    /// Mesh order as a number.
    pub mesh_order: f64,
    /// Mesh frequency, Hz (`null` without a sample rate).
    pub mesh_hz: Option<f64>,
    /// Mesh harmonics 1..=3 with their sideband families.
    pub mesh_harmonics: Vec<StageHarmonic>,
    /// A planetary stage's characteristic orders and planet averages.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planetary: Option<PlanetaryDiagnosis>,
}

/// Kind of stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StageKind {
    /// A parallel pair.
    Parallel,
    /// A planetary stage.
    Planetary,
}

/// A gear of a stage.
#[derive(Clone, Debug, Serialize)]
pub struct StageGear {
    /// `pinion` (the driving gear of a parallel stage), `wheel` (its driven gear), `sun`, `planet`, `ring`.
    pub gear: VerdictGear,
    /// The shaft carrying it (`null` for a fixed member and for the planets, which turn on the carrier).
    pub shaft: Option<String>,
    /// Teeth.
    pub teeth: u32,
}

/// A mesh harmonic of a stage with its sideband families.
#[derive(Clone, Debug, Serialize)]
pub struct StageHarmonic {
    /// Harmonic number.
    pub k: u32,
    /// Order of the tracked shaft.
    pub order: f64,
    /// Frequency, Hz (`null` without a sample rate).
    pub frequency_hz: Option<f64>,
    /// Peak amplitude in the deciding channel's spectrum (`null` when the line lies beyond it).
    pub amplitude: Option<f64>,
    /// Sidebands of every family.
    pub sidebands: Vec<MachineSideband>,
}

/// A sideband of a stage's mesh harmonic.
#[derive(Clone, Debug, Serialize)]
pub struct MachineSideband {
    /// Offset in multiples of the family's spacing (negative below the mesh line).
    pub offset: i32,
    /// The shaft whose rotation spaces the family, or `planet pass`.
    pub family: String,
    /// Order of the tracked shaft.
    pub order: f64,
    /// Frequency, Hz.
    pub frequency_hz: Option<f64>,
    /// Peak amplitude.
    pub amplitude: Option<f64>,
    /// False when a line of another family or stage lies within three spectral bins (the amplitude cannot be
    /// attributed to this family).
    pub resolved: bool,
}

/// A planetary stage's characteristic orders (of the tracked shaft) and frequencies, and its planets'
/// separated averages.
#[derive(Clone, Debug, Serialize)]
pub struct PlanetaryDiagnosis {
    /// Planets.
    pub planets: usize,
    /// Carrier angle of each planet's passage at the sensor after planet 1, degrees.
    pub planet_angles_deg: Vec<f64>,
    /// Characteristic orders: `planet_pass`, `sun_fault`, `planet_fault`, `planet_fault_both`, `ring_fault`,
    /// `carrier`, `planet_relative`.
    pub orders: BTreeMap<String, f64>,
    /// The same in Hz (empty without a sample rate).
    pub frequencies_hz: BTreeMap<String, f64>,
    /// Each planet's separated average and its indicators (empty when the carrier's angle is not known
    /// exactly enough or the recording too short).
    pub planet_averages: Vec<PlanetIndicators>,
    /// Per planet, the energy of the planet-fault order family (orders m z_r / z_p of the carrier, m = 1..3)
    /// in the squared tooth-to-tooth difference (y(theta) - y(theta - one ring tooth), which removes the
    /// meshing locally and keeps a fault's burst) gated to that planet's passage at the sensor (+-20 degrees
    /// of carrier angle, Hann), per sample squared: a planet's local fault repeats once per planet revolution
    /// relative to the carrier and is seen strongest while that planet passes the sensor.
    pub planet_fault_energy: Vec<f64>,
    /// Why there are no planet averages, when there are none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_averages: Option<String>,
}

/// One planet's separated average.
#[derive(Clone, Debug, Serialize)]
pub struct PlanetIndicators {
    /// Planet, 1-based.
    pub planet: usize,
    /// Passes averaged.
    pub passes: usize,
    /// Indicators of the average (FM4, M6A, kurtosis, RMS of its difference signal...).
    pub indicators: super::Indicators,
    /// The average over one planet revolution relative to the carrier.
    #[serde(skip)]
    pub samples: Vec<f64>,
    /// Its difference signal (planet mesh harmonics and their first sidebands removed).
    #[serde(skip)]
    pub difference: Vec<f64>,
}

/// The healthy planet-fault energies of one planetary stage (each planet's
/// [`PlanetaryDiagnosis::planet_fault_energy`], the mean over the healthy recordings): what a planet's is
/// compared with. A profile stores them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanetBaseline {
    /// Stage, 1-based.
    pub stage: usize,
    /// Per planet, the mean over the healthy recordings.
    pub planet_fault_energy: Vec<f64>,
}

impl PlanetBaseline {
    /// The mean planet-fault energies of every planetary stage over `healthy` (machine diagnoses of the
    /// same machine); stages with a recording that gave none are left out.
    pub fn of<'a>(healthy: impl IntoIterator<Item = &'a MachineDiagnosis>) -> Vec<PlanetBaseline> {
        let mut sums: Vec<(usize, Vec<f64>, usize)> = Vec::new();
        let mut incomplete: Vec<usize> = Vec::new();
        for md in healthy {
            for s in &md.stages {
                let Some(p) = &s.planetary else { continue };
                match sums.iter_mut().find(|x| x.0 == s.stage) {
                    Some(x) if x.1.len() == p.planet_fault_energy.len() && !p.planet_fault_energy.is_empty() => {
                        x.1.iter_mut().zip(&p.planet_fault_energy).for_each(|(a, b)| *a += b);
                        x.2 += 1;
                    }
                    Some(_) => incomplete.push(s.stage),
                    None if p.planet_fault_energy.is_empty() => incomplete.push(s.stage),
                    None => sums.push((s.stage, p.planet_fault_energy.clone(), 1)),
                }
            }
        }
        sums.into_iter()
            .filter(|x| !incomplete.contains(&x.0))
            .map(|(stage, sum, n)| PlanetBaseline {
                stage,
                planet_fault_energy: sum.iter().map(|v| v / n as f64).collect(),
            })
            .collect()
    }
}
