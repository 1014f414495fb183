//! The verdict: condition indicators judged against a healthy baseline of the same machine (ratios), or
//! against absolute limits without one; NA4 over the ensemble of recordings in time order.

use crate::report::summary::{Diagnosis, GearIndicators, Shaft, Verdict, VerdictGear, VerdictState};
use crate::signal::indicators as ind;
use std::collections::BTreeMap;

/// A pair of limits: at `suspect` or above the indicator makes a recording suspect, at `faulty` faulty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// First limit (suspect).
    pub suspect: f64,
    /// Second limit (faulty).
    pub faulty: f64,
}

/// Every number the verdict uses, in one place.
///
/// Ratios are "value now / value in the baseline"; absolute limits apply only without a baseline.
/// Where they come from: a healthy mesh's difference and residual signals are close to Gaussian noise,
/// whose kurtosis is 3 (FM4, NA4) and whose normalised sixth moment is 15 (M6A); the absolute limits sit at
/// 1.5x and 2x those values (FM4/NA4: 4.5 and 6) and at about 2.7x and 5.3x for the more scattered M6A
/// (40 and 80). SER and SI ratios of 2 and 3 are sideband growth of +6 dB and +9.5 dB. The baseline ratios
/// of NA4* and M6A (1.5, 2) are looser than FM4's (1.25, 1.5) because higher moments scatter more between
/// recordings of one healthy gear. These are engineering choices checked on the bundled simulated and real
/// recordings (tests/diagnose.rs), not values from a standard.
#[derive(Clone, Debug, PartialEq)]
pub struct Thresholds {
    /// NA4* (residual fourth moment over the baseline's residual variance) against the baseline's NA4.
    pub na4_star_ratio: Limits,
    /// M6A against the baseline's M6A.
    pub m6a_ratio: Limits,
    /// FM4 against the baseline's FM4.
    pub fm4_ratio: Limits,
    /// SER against the baseline's SER.
    pub ser_ratio: Limits,
    /// SI against the baseline's SI.
    pub si_ratio: Limits,
    /// FM4 without a baseline (3 for a healthy mesh).
    pub fm4_absolute: Limits,
    /// M6A without a baseline (15 for a healthy mesh).
    pub m6a_absolute: Limits,
    /// NA4 without a baseline (3 nominal).
    pub na4_absolute: Limits,
    /// Number of indicators at their first limit that together make a recording faulty.
    pub faulty_count: usize,
    /// Reasons listed in the verdict, strongest first.
    pub max_reasons: usize,
}

impl Default for Thresholds {
    fn default() -> Self {
        Self {
            na4_star_ratio: Limits { suspect: 1.5, faulty: 2.0 },
            m6a_ratio: Limits { suspect: 1.5, faulty: 2.0 },
            fm4_ratio: Limits { suspect: 1.25, faulty: 1.5 },
            ser_ratio: Limits { suspect: 2.0, faulty: 3.0 },
            si_ratio: Limits { suspect: 2.0, faulty: 3.0 },
            fm4_absolute: Limits { suspect: 4.5, faulty: 6.0 },
            m6a_absolute: Limits { suspect: 40.0, faulty: 80.0 },
            na4_absolute: Limits { suspect: 4.5, faulty: 6.0 },
            faulty_count: 2,
            max_reasons: 6,
        }
    }
}

/// Nominal values of a healthy mesh for the absolute limits (Gaussian noise moments).
const NOMINAL_FM4: f64 = 3.0;
const NOMINAL_M6A: f64 = 15.0;
const NOMINAL_NA4: f64 = 3.0;

/// Fills NA4 over the ensemble (recordings in time order): NA4 of record M uses the mean residual sum of
/// squares of records 1..=M of the same gear and channel.
pub fn ensemble_na4(results: &mut [Diagnosis]) {
    let mut history: BTreeMap<(Shaft, usize), Vec<f64>> = BTreeMap::new();
    for d in results.iter_mut() {
        for g in &mut d.gears {
            let h = history.entry((g.gear, g.channel)).or_default();
            h.push(ind::sum_sq_dev(&g.residual));
            g.indicators.insert("na4".into(), ind::na4(&g.residual, h));
        }
        if let Some(g) = d.gears.first() {
            d.indicators = g.indicators.clone();
        }
    }
}

struct Trigger {
    state: VerdictState,
    ratio: f64,
    text: String,
}

fn level(value: f64, limits: Limits) -> Option<VerdictState> {
    if !value.is_finite() || value < limits.suspect {
        None
    } else if value >= limits.faulty {
        Some(VerdictState::Faulty)
    } else {
        Some(VerdictState::Suspect)
    }
}

fn get(m: &BTreeMap<String, f64>, k: &str) -> f64 {
    m.get(k).copied().unwrap_or(f64::NAN)
}

/// NA4*: the residual's fourth moment over the baseline residual's variance squared.
fn na4_star(g: &GearIndicators, b: &GearIndicators) -> f64 {
    let n = g.residual.len() as f64;
    let ss_b = ind::sum_sq_dev(&b.residual);
    let mean = g.residual.iter().sum::<f64>() / n;
    let s4: f64 = g.residual.iter().map(|v| (v - mean).powi(4)).sum();
    n * s4 / (ss_b * ss_b)
}

fn against_baseline(g: &mut GearIndicators, b: &GearIndicators, t: &Thresholds) -> Vec<Trigger> {
    let na4s = na4_star(g, b);
    g.indicators.insert("na4_star".into(), na4s);
    let checks = [
        (
            "NA4*",
            na4s,
            ind::kurtosis(&b.residual),
            t.na4_star_ratio,
            "the residual signal (TSA without shaft and mesh lines) has grown and become impulsive",
        ),
        (
            "M6A",
            get(&g.indicators, "m6a"),
            get(&b.indicators, "m6a"),
            t.m6a_ratio,
            "the difference signal has sharper peaks",
        ),
        (
            "FM4",
            get(&g.indicators, "fm4"),
            get(&b.indicators, "fm4"),
            t.fm4_ratio,
            "the difference signal is more impulsive",
        ),
        (
            "SER",
            get(&g.indicators, "ser"),
            get(&b.indicators, "ser"),
            t.ser_ratio,
            "the sidebands around the mesh line have grown",
        ),
        (
            "SI",
            get(&g.indicators, "si"),
            get(&b.indicators, "si"),
            t.si_ratio,
            "the first sidebands of the mesh line have grown",
        ),
    ];
    let mut out = Vec::new();
    for (name, now, then, limits, why) in checks {
        let r = now / then;
        if let Some(state) = level(r, limits) {
            out.push(Trigger {
                state,
                ratio: r,
                text: format!(
                    "{} (channel {}): {name} {now:.3} against {then:.3} in the baseline (x{r:.2}): {why}",
                    g.gear, g.channel
                ),
            });
        }
    }
    out
}

fn absolute(g: &GearIndicators, t: &Thresholds) -> Vec<Trigger> {
    let checks = [
        (
            "FM4",
            get(&g.indicators, "fm4"),
            t.fm4_absolute,
            NOMINAL_FM4,
            "difference signal impulsive (3 for a healthy mesh)",
        ),
        (
            "M6A",
            get(&g.indicators, "m6a"),
            t.m6a_absolute,
            NOMINAL_M6A,
            "difference signal has sharp peaks (15 for a healthy mesh)",
        ),
        ("NA4", get(&g.indicators, "na4"), t.na4_absolute, NOMINAL_NA4, "residual signal impulsive (3 nominal)"),
    ];
    let mut out = Vec::new();
    for (name, now, limits, nominal, why) in checks {
        if let Some(state) = level(now, limits) {
            out.push(Trigger {
                state,
                ratio: now / nominal,
                text: format!("{} (channel {}): {name} = {now:.3}: {why}", g.gear, g.channel),
            });
        }
    }
    out
}

/// The state a gear's triggers give: the worst single one, or faulty when `faulty_count` fire together.
fn gear_state(triggers: &[Trigger], t: &Thresholds) -> VerdictState {
    let top = triggers.iter().map(|x| x.state).max().unwrap_or(VerdictState::Healthy);
    if triggers.len() >= t.faulty_count { VerdictState::Faulty } else { top }
}

/// Verdict relative to a baseline diagnosis of the same machine, or on absolute limits without one.
pub fn judge(d: &mut Diagnosis, baseline: Option<&Diagnosis>, t: &Thresholds) {
    let mut per_gear: Vec<(Shaft, usize, Vec<Trigger>)> = Vec::new();
    for g in &mut d.gears {
        let trig = match baseline.and_then(|b| b.gears.iter().find(|x| x.gear == g.gear && x.channel == g.channel)) {
            Some(b) => against_baseline(g, b, t),
            None => absolute(g, t),
        };
        per_gear.push((g.gear, g.channel, trig));
    }
    let strongest = |x: &[Trigger]| x.iter().map(|t| t.ratio).fold(0.0, f64::max);
    let worst = per_gear.iter().max_by(|a, b| {
        (gear_state(&a.2, t), strongest(&a.2))
            .partial_cmp(&(gear_state(&b.2, t), strongest(&b.2)))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut reasons = Vec::new();
    let (state, gear) = match worst {
        Some((gear, channel, trig)) if gear_state(trig, t) > VerdictState::Healthy => {
            let mut all: Vec<&Trigger> = per_gear.iter().flat_map(|g| &g.2).collect();
            all.sort_by(|a, b| b.ratio.total_cmp(&a.ratio));
            reasons.extend(all.iter().take(t.max_reasons).map(|t| t.text.clone()));
            if let Some(g) = d.gears.iter().find(|g| g.gear == *gear && g.channel == *channel) {
                d.indicators = g.indicators.clone();
            }
            (gear_state(trig, t), VerdictGear::from(*gear))
        }
        _ => {
            reasons.push(match baseline {
                Some(_) => "no condition indicator rose above its threshold relative to the baseline".into(),
                None => {
                    "FM4, M6A and NA4 are within their healthy ranges (no baseline given: absolute thresholds)".into()
                }
            });
            (VerdictState::Healthy, VerdictGear::None)
        }
    };
    if baseline.is_none() {
        reasons.push("without a baseline only absolute thresholds apply; a healthy recording of the same machine makes the verdict much stronger".into());
    }
    d.verdict = Verdict { state, gear, reasons };
}
