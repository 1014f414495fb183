//! `diagnose --machine`: a gearbox of several stages (DESIGN.md section 4) through the one pipeline.
//!
//! ```text
//! tracked shaft t: the tachometer's shaft when its pulses are used, else the shaft of the given speed
//!     (the machine's `speed.shaft`, else its reference shaft); its angle is tracked as a pair's pinion is
//!     (`--teeth z_t,z_mate` of its first stage), so every tracking path of the pair serves the machine
//! shaft j: angle_j = |w_j / w_t| angle_t (exact ratio chain), its TSA on that angle; a shaft carrying
//!     several gears (an intermediate shaft) has every one of their mesh families removed from its
//!     residual and difference signals
//! stage k: mesh harmonics h m_k (m_k = mesh order over w_t; h = 1.. up to 0.45 fs, at most 16), sideband
//!     families +-n w_j of every shaft j on the stage (and +-n planet-pass for a planetary stage), read on
//!     the deciding channel's spectrum
//! planetary stage: planet pass, sun / planet / ring fault orders (model::kinematics), the planets'
//!     averages by vibration separation on the carrier's angle (signal::planetary)
//! verdict: the pair's judgement over the shafts' averages, then named: the stage and gear on the deciding
//!     shaft (two gears on one shaft: the one whose mesh band holds the impulse), its tooth; a planet whose
//!     separated average stands out from the other planets' is named instead
//! ```

use super::analysis::{Analysed, analyse_parts};
use super::tooth::{concentration, impulse_tooth, moved_for_a_tooth};
use super::*;
use crate::model::kinematics::{Machine, Member, Ratio, Stage};
use crate::report::summary::{
    MachineDiagnosis, MachineSideband, NamedHz, StageDiagnosis, StageGear, StageHarmonic, StageKind, ToothOrigin,
};

mod planets;
use planets::{name_planet, planetary};

/// A shaft averaged by the pipeline: its key, its index in the machine, its speed over the tracked
/// shaft's and the whole mesh orders of its gears (the first is the one its indicators use).
pub(super) struct AveragedShaft {
    pub shaft: Shaft,
    pub ratio: f64,
    pub mesh_orders: Vec<usize>,
    /// Its gears' mesh orders after the first, and the other stages' mesh harmonics in its orders.
    pub others: super::analysis::OtherLines,
}

/// Mesh harmonics of the other stages masked in a shaft's residual: a mesh's energy sits in its first few
/// harmonics, and each masked line takes two bins of the shaft's spectrum from the residual.
const FOREIGN_HARMONICS: usize = 6;

/// A gear on a shaft: its stage (0-based), what it is, its teeth, and its mesh order over that shaft's
/// rotation when it is whole (a sun's mesh over its own shaft generally is not).
#[derive(Clone, Copy, Debug)]
struct ShaftGear {
    stage: usize,
    gear: VerdictGear,
    teeth: u32,
    mesh_order: Option<usize>,
}

/// The gears that shaft `i` carries (for a planetary stage, the carrier "carries" the planets: their
/// meshes repeat with it).
fn shaft_gears(m: &Machine, i: usize) -> Vec<ShaftGear> {
    let whole = |k: usize| -> Option<usize> {
        let o = m.mesh_order(k)?.checked_div(m.order(i).abs())?;
        (o.den() == 1 && o.num() > 0).then(|| usize::try_from(o.num()).ok()).flatten()
    };
    let mut out = Vec::new();
    for (k, stage) in m.stages.iter().enumerate() {
        match stage {
            Stage::Parallel(p) => {
                if p.driving == i {
                    out.push(ShaftGear {
                        stage: k,
                        gear: VerdictGear::Pinion,
                        teeth: p.driving_teeth,
                        mesh_order: Some(p.driving_teeth as usize),
                    });
                }
                if p.driven == i {
                    out.push(ShaftGear {
                        stage: k,
                        gear: VerdictGear::Wheel,
                        teeth: p.driven_teeth,
                        mesh_order: Some(p.driven_teeth as usize),
                    });
                }
            }
            Stage::Planetary(p) => {
                for (member, gear, teeth) in [
                    (p.sun, VerdictGear::Sun, p.sun_teeth),
                    (p.ring, VerdictGear::Ring, p.ring_teeth),
                    (p.carrier, VerdictGear::Planet, p.planet_teeth),
                ] {
                    if member == Member::Shaft(i) {
                        out.push(ShaftGear { stage: k, gear, teeth, mesh_order: whole(k) });
                    }
                }
            }
        }
    }
    out
}

/// The shaft whose angle is tracked: the tachometer's when its pulses are used, else the speed's shaft
/// (or the machine's reference).
fn tracked(m: &Machine, o: &Options) -> usize {
    match (&m.tachometer, o.tacho_channel) {
        (Some(t), Some(c)) if t.channel as usize == c => t.shaft,
        _ => m.speed.as_ref().map_or(m.reference(), |s| s.shaft),
    }
}

/// Every shaft with a gear of whole mesh order, the tracked shaft first (see the module doc).
pub(super) fn averaged_shafts(m: &Machine, o: &Options) -> Vec<AveragedShaft> {
    let t = tracked(m, o);
    std::iter::once(t)
        .chain((0..m.shafts.len()).filter(|&i| i != t))
        .filter_map(|i| {
            let gears = shaft_gears(m, i);
            let mesh_orders: Vec<usize> = gears.iter().filter_map(|g| g.mesh_order).collect();
            let own: Vec<usize> = gears.iter().map(|g| g.stage).collect();
            let speed = m.order(i).abs().to_f64();
            // the stages this shaft does not carry: their mesh harmonics in its orders (whole ones too, when
            // the stages share a short common period: another gear's mesh line, not this gear's residual)
            let foreign: Vec<f64> = (0..m.stages.len())
                .filter(|k| !own.contains(k))
                .filter_map(|k| m.mesh_order(k).map(|r| r.to_f64() / speed))
                .flat_map(|f| (1..=FOREIGN_HARMONICS).map(move |h| h as f64 * f))
                .collect();
            (!mesh_orders.is_empty()).then(|| AveragedShaft {
                shaft: Shaft::named(&m.shafts[i]),
                ratio: m.ratio(i, t).abs().to_f64(),
                others: super::analysis::OtherLines { mesh: mesh_orders[1..].to_vec(), foreign },
                mesh_orders,
            })
        })
        .collect()
}

/// Every shaft's frequency, the tracked shaft's (`tracked_hz`) times its exact ratio; the tracked shaft
/// first.
pub(super) fn shaft_hz(o: &Options, tracked_hz: Option<f64>) -> ShaftHz {
    let Some(m) = o.machine.as_ref().map(|m| m.machine()) else {
        return ShaftHz::Pinion { pinion: tracked_hz };
    };
    let t = tracked(m, o);
    ShaftHz::Machine(NamedHz(
        std::iter::once(t)
            .chain((0..m.shafts.len()).filter(|&i| i != t))
            .map(|i| (Shaft::named(&m.shafts[i]), tracked_hz.map(|f| f * m.ratio(i, t).abs().to_f64())))
            .collect(),
    ))
}

/// The pair options that track the machine's tracked shaft: its teeth and its mate's, its nominal speed
/// (the given speed or the file's, through the ratio chain), the tachometer, the sensors' unit.
///
/// # Errors
/// [`JobError::Input`] when the tracked shaft carries no gear of whole mesh order (its angle cannot be
/// followed on a mesh line), naming the machine's fields.
fn pair_options(path: &Path, o: &Options, m: &Machine) -> Result<Options, Error> {
    let mut p = o.clone();
    // the speed: given (of the machine's speed shaft), else the file's nominal one unless a tachometer is used
    let speed_shaft = m.speed.as_ref().map_or(m.reference(), |s| s.shaft);
    let use_tacho = o.shaft_hz.is_none() && o.tacho_channel.is_none() && m.tachometer.is_some();
    if use_tacho {
        if let Some(t) = &m.tachometer {
            p.tacho_channel = Some(t.channel as usize);
            p.pulses_per_rev = t.pulses_per_rev as usize;
        }
    }
    let t = tracked(m, &p);
    let given = o.shaft_hz.map(|hz| (hz, o.speed_tolerance)).or_else(|| {
        (p.tacho_channel.is_none()).then_some(m.speed.as_ref()).flatten().map(|s| (s.nominal_rpm / 60.0, s.tolerance))
    });
    p.shaft_hz = given.map(|(hz, _)| hz * m.ratio(t, speed_shaft).abs().to_f64());
    if let Some((_, tol)) = given {
        p.speed_tolerance = tol.min(0.2);
    }
    let gears = shaft_gears(m, t);
    let Some(first) = gears.iter().find(|g| g.mesh_order.is_some()) else {
        return Err(bad(
            path,
            format!(
                "the machine's tracked shaft `{}` (field `{}`) carries no gear whose mesh is a whole order of it, so its angle cannot be followed on a mesh line: put the tachometer or the speed on a shaft of a parallel stage or on the carrier of a fixed ring",
                m.shafts[t],
                if p.tacho_channel.is_some() { "tachometer.shaft" } else { "speed.shaft" }
            ),
        ));
    };
    let z = first.mesh_order.unwrap_or(first.teeth as usize);
    let mate = match &m.stages[first.stage] {
        Stage::Parallel(s) if s.driving == t => s.driven_teeth,
        Stage::Parallel(s) => s.driving_teeth,
        Stage::Planetary(s) => s.planet_teeth,
    };
    p.teeth = Some((z, mate as usize));
    if p.unit.is_none() {
        if let Some(s) = m.sensors.first() {
            p.unit = Some(s.unit.name().to_string());
            if p.sensitivity.is_none() && s.sensitivity != 1.0 {
                p.sensitivity = Some(s.sensitivity);
            }
        }
    }
    Ok(p)
}

/// Refuses a recording that lacks a channel the machine names.
///
/// # Errors
/// [`JobError::Input`] naming the machine's field and the recording's channel count.
fn check_channels(path: &Path, rec: &Recording, m: &Machine, o: &Options) -> Result<(), Error> {
    let n = rec.channels.len();
    let named = m.sensors.iter().enumerate().map(|(i, s)| (format!("sensors[{i}].channel"), s.channel as usize)).chain(
        m.tachometer
            .iter()
            .filter(|_| o.tacho_channel.is_some())
            .map(|t| ("tachometer.channel".into(), t.channel as usize)),
    );
    for (field, c) in named {
        if c == 0 || c > n {
            return Err(bad(
                path,
                format!("the machine's field `{field}` names channel {c}, but the recording has {n} channel(s)"),
            ));
        }
    }
    Ok(())
}

/// Diagnoses one recording of machine `m` (`o.machine`).
///
/// # Errors
/// As the pair's diagnosis, and a recording that does not fit the machine.
pub(super) fn diagnose(path: &Path, o: &Options, m: &Machine, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
    let p = pair_options(path, o, m)?;
    let (rec, p) = read(path, &p)?;
    analyse_machine(path, rec, &p, m, geometry)
}

/// [`diagnose`] of a recording held in memory.
///
/// # Errors
/// As [`diagnose`].
pub(super) fn diagnose_in_memory(
    name: &Path,
    mut rec: Recording,
    o: &Options,
    m: &Machine,
    geometry: Option<&Geometry>,
) -> Result<Diagnosis, Error> {
    let p = pair_options(name, o, m)?;
    apply_units(&mut rec, &p, p.tacho_channel);
    analyse_machine(name, rec, &p, m, geometry)
}

fn analyse_machine(
    path: &Path,
    rec: Recording,
    p: &Options,
    m: &Machine,
    geometry: Option<&Geometry>,
) -> Result<Diagnosis, Error> {
    check_channels(path, &rec, m, p)?;
    let Analysed { mut diagnosis, map, deciding } = analyse_parts(path, rec, p, geometry)?;
    let t = tracked(m, p);
    let mut fft = Fft::new();
    let cx = StageContext { d: &diagnosis, m, t, map: &map, deciding: &deciding, o: p };
    let stages = (0..m.stages.len()).map(|k| stage(&mut fft, &cx, k)).collect();
    if t != m.reference() || m.tachometer.as_ref().is_some_and(|x| x.shaft != t) {
        diagnosis.warnings.push(format!(
            "orders and the averages' angles are those of the tracked shaft `{}`; every other shaft's angle is it times the exact ratio",
            m.shafts[t]
        ));
    }
    diagnosis.machine = Some(MachineDiagnosis { machine: m.name.clone(), tracked_shaft: m.shafts[t].clone(), stages });
    Ok(diagnosis)
}

/// Order of the tracked shaft `t` of machine order `r` (relative to the machine's reference).
fn tracked_order(m: &Machine, t: usize, r: Ratio) -> f64 {
    r.to_f64() / m.order(t).abs().to_f64()
}

/// What every stage of one recording is read against: the pair pipeline's diagnosis, the machine, the
/// tracked shaft, its angle map, the deciding channel's samples and the options.
#[derive(Clone, Copy)]
struct StageContext<'a> {
    d: &'a Diagnosis,
    m: &'a Machine,
    /// Index of the tracked shaft.
    t: usize,
    map: &'a AngleMap,
    deciding: &'a [f32],
    o: &'a Options,
}

/// Stage `k`'s gears, lines and (planetary) orders and planet averages.
fn stage(fft: &mut Fft, cx: &StageContext<'_>, k: usize) -> StageDiagnosis {
    let StageContext { d, m, t, .. } = *cx;
    let mesh = m.mesh_order(k).unwrap_or(Ratio::ZERO);
    let f_t = d.shaft_hz.reference();
    let gears = match &m.stages[k] {
        Stage::Parallel(p) => vec![
            StageGear { gear: VerdictGear::Pinion, shaft: Some(m.shafts[p.driving].clone()), teeth: p.driving_teeth },
            StageGear { gear: VerdictGear::Wheel, shaft: Some(m.shafts[p.driven].clone()), teeth: p.driven_teeth },
        ],
        Stage::Planetary(p) => {
            let name = |mb: Member| if let Member::Shaft(i) = mb { Some(m.shafts[i].clone()) } else { None };
            vec![
                StageGear { gear: VerdictGear::Sun, shaft: name(p.sun), teeth: p.sun_teeth },
                StageGear { gear: VerdictGear::Planet, shaft: None, teeth: p.planet_teeth },
                StageGear { gear: VerdictGear::Ring, shaft: name(p.ring), teeth: p.ring_teeth },
            ]
        }
    };
    let mesh_order = tracked_order(m, t, mesh);
    StageDiagnosis {
        stage: k + 1,
        kind: match m.stages[k] {
            Stage::Parallel(_) => StageKind::Parallel,
            Stage::Planetary(_) => StageKind::Planetary,
        },
        gears,
        mesh_order_exact: Ratio::new(mesh.num() * m.order(t).den(), mesh.den() * m.order(t).num().abs())
            .unwrap_or(Ratio::ZERO)
            .to_string(),
        mesh_order,
        mesh_hz: f_t.map(|f| f * mesh_order),
        mesh_harmonics: harmonics(d, m, t, k),
        planetary: matches!(m.stages[k], Stage::Planetary(_)).then(|| planetary(fft, cx, k)),
    }
}

/// Most mesh harmonics listed per stage: the first 16 (as many as the mesh comb searches,
/// [`crate::signal::mesh_comb::MAX_HARMONICS`]); a slow stage recorded fast would otherwise list fifty, each
/// with its families, in every table.
pub const MAX_STAGE_HARMONICS: u32 = 16;

/// Highest frequency of a listed line, as a fraction of the sample rate: 0.45, below the roll-off of a
/// recorder's anti-alias filter (the order map stops there too).
pub const LISTED_BAND: f64 = 0.45;

/// Mesh harmonics listed for a stage meshing at `mesh_hz` in a recording sampled at `sample_rate_hz`:
/// every harmonic up to [`LISTED_BAND`] times the sample rate, at most [`MAX_STAGE_HARMONICS`]; 3 when the
/// frequency is not known (no speed, or no sample rate: orders only).
pub fn listed_harmonics(mesh_hz: Option<f64>, sample_rate_hz: Option<f64>) -> u32 {
    match (mesh_hz, sample_rate_hz) {
        (Some(f), Some(fs)) if f > 0.0 && fs > 0.0 => {
            (LISTED_BAND * fs / f).floor().min(f64::from(MAX_STAGE_HARMONICS)) as u32
        }
        _ => 3,
    }
}

/// Mesh harmonics of stage `k` ([`listed_harmonics`]) and their sideband families (+-1..3 of each shaft on
/// the stage and of the planet pass) on the deciding channel's spectrum.
fn harmonics(d: &Diagnosis, m: &Machine, t: usize, k: usize) -> Vec<StageHarmonic> {
    use crate::model::kinematics::LineKind;
    let f_t = d.shaft_hz.reference();
    let listed = |stage: usize| {
        let mesh_hz = f_t.zip(m.mesh_order(stage)).map(|(f, r)| f * tracked_order(m, t, r));
        listed_harmonics(mesh_hz, d.sample_rate_hz)
    };
    let most = (0..m.stages.len()).map(listed).max().unwrap_or(0);
    let lines = m.labelled_lines(most, 3);
    let spectrum = d.spectra.iter().find(|s| Some(&s.0) == d.channels.first()).map(|s| &s.1);
    let df = spectrum.and_then(|s| s.freqs_hz.get(1).copied()).unwrap_or(1.0);
    let read = |order: f64| -> (Option<f64>, Option<f64>) {
        match (spectrum, f_t) {
            (Some(s), Some(f)) => match s.hann_line_near(order * f, 1.5 * df) {
                Some((ff, a)) => (Some(ff), Some(a)),
                None => (Some(order * f), None),
            },
            (None, Some(f)) => (Some(order * f), None),
            _ => (None, None),
        }
    };
    // every line's order and family (stage, family name) for the resolution check
    let family = |l: &crate::model::kinematics::Line| -> (usize, String) {
        match l.kind {
            LineKind::Mesh { .. } => (l.stage, "mesh".into()),
            LineKind::ShaftSideband { shaft, .. } => (l.stage, m.shafts[shaft].clone()),
            LineKind::PlanetPassSideband { .. } => (l.stage, "planet pass".into()),
        }
    };
    let all: Vec<(f64, (usize, String))> = lines.iter().map(|l| (tracked_order(m, t, l.order), family(l))).collect();
    let resolution = f_t.map_or(0.0, |f| 3.0 * df / f);
    let mut out = Vec::new();
    for h in 1..=listed(k) {
        let Some(centre) = lines.iter().find(|l| l.stage == k && l.kind == LineKind::Mesh { harmonic: h }) else {
            continue;
        };
        let order = tracked_order(m, t, centre.order);
        let (frequency_hz, amplitude) = read(order);
        let sidebands = lines
            .iter()
            .filter(|l| l.stage == k)
            .filter_map(|l| {
                let offset = match l.kind {
                    LineKind::ShaftSideband { harmonic, n, .. } | LineKind::PlanetPassSideband { harmonic, n }
                        if harmonic == h =>
                    {
                        n
                    }
                    _ => return None,
                };
                let o = tracked_order(m, t, l.order);
                let fam = family(l);
                let (frequency_hz, amplitude) = read(o);
                Some(MachineSideband {
                    offset,
                    resolved: !all.iter().any(|(o2, f2)| *f2 != fam && (o2 - o).abs() < resolution),
                    family: fam.1,
                    order: o,
                    frequency_hz,
                    amplitude,
                })
            })
            .collect();
        out.push(StageHarmonic { k: h, order, frequency_hz, amplitude, sidebands });
    }
    out
}

/// Names the machine's stage, gear and tooth in a suspect or faulty verdict (see the module doc), or a
/// planet whose average stands out.
pub(super) fn name_verdict(
    d: &mut Diagnosis,
    m: &Machine,
    o: &Options,
    baseline: Option<&BaselinePlots>,
    planets: Option<&[crate::report::summary::PlanetBaseline]>,
) {
    if name_planet(d, planets) {
        return;
    }
    if d.verdict.state < VerdictState::Suspect {
        return;
    }
    let Some(Shaft::Named(name)) = d.verdict.deciding else { return };
    let Some(i) = m.shaft_index(name) else { return };
    let gears: Vec<ShaftGear> = shaft_gears(m, i).into_iter().filter(|g| g.mesh_order.is_some()).collect();
    let channel = d.channels.first().copied();
    let Some(g) = d.gears.iter().find(|g| g.gear == Shaft::Named(name) && Some(g.channel) == channel).cloned() else {
        return;
    };
    let healthy = baseline.and_then(|(_, tsas)| {
        tsas.iter().find(|b| b.0 == g.channel && b.1 == g.gear && b.2.len() == g.tsa.len()).map(|b| b.2.as_slice())
    });
    let (chosen, why) = match (gears.as_slice(), healthy) {
        ([], _) => return,
        ([one], _) => (*one, None),
        (many, h) => choose_by_band(&g.tsa, h, many),
    };
    d.verdict.gear = chosen.gear;
    d.verdict.stage = Some(chosen.stage + 1);
    d.verdict.shaft = Some(name.to_string());
    d.verdict.planet = None;
    if let Some(why) = why {
        d.verdict.reasons.insert(0, why);
    }
    // a tooth only when the shaft's own indicators moved as a tooth's fault moves them (a verdict from the
    // envelope or SBR alone names the gear; without a baseline there are no scores and the indicators decided)
    let moved = d.scores.is_empty() || moved_for_a_tooth(&d.scores, &Shaft::Named(name));
    let z = chosen.mesh_order.unwrap_or(chosen.teeth as usize);
    let signal = [&g.difference, &g.residual].into_iter().find(|x| moved && concentration(x, z) >= 3.0);
    if let Some(tooth) = signal.and_then(|x| impulse_tooth(x, z)) {
        let t = tracked(m, o);
        d.verdict.tooth = Some(tooth);
        d.verdict.tooth_origin = Some(match (i == t, d.speed_profile.tracking.tachometer_origin()) {
            (true, true) => ToothOrigin::Tachometer,
            (false, true) => ToothOrigin::Relative,
            (_, false) => ToothOrigin::Arbitrary,
        });
        if i != t {
            d.verdict.reasons.push(format!(
                "tooth {tooth} of the {} is counted from the `{name}` shaft's angle at the start of the tracked shaft `{}`'s first revolution used (its angle there times the exact ratio {}): a relative origin, since no tachometer watches `{name}`",
                chosen.gear,
                m.shafts[t],
                m.ratio(i, t).abs()
            ));
        }
    }
}

/// Of several gears on one shaft, the one whose mesh band holds the impulse (gearboxes.md section 4.5: a
/// local fault modulates its own stage's mesh): the average's orders are shared out to the nearest mesh
/// harmonic of any of the shaft's gears, the mesh lines and their first sidebands left out, and the gear
/// whose band is the more impulsive (kurtosis of the band's signal over one revolution; over the same
/// band's kurtosis in the healthy baseline's average when there is one) is named, with the reason.
fn choose_by_band(tsa: &[f64], healthy: Option<&[f64]>, gears: &[ShaftGear]) -> (ShaftGear, Option<String>) {
    let mut fft = Fft::new();
    let orders: Vec<usize> = gears.iter().filter_map(|g| g.mesh_order).collect();
    let owner = |k: usize| -> Option<usize> {
        // the nearest mesh harmonic (of any gear); none on a mesh line or its first sidebands
        let mut best: Option<(usize, usize)> = None;
        for (gi, &z) in orders.iter().enumerate() {
            let h = ((k as f64 / z as f64).round() as usize).max(1);
            let dist = k.abs_diff(h * z);
            if dist <= 1 {
                return None;
            }
            if best.is_none_or(|b| dist < b.1) {
                best = Some((gi, dist));
            }
        }
        best.map(|b| b.0)
    };
    let band_kurtosis = |x: &[f64], fft: &mut Fft| -> Vec<f64> {
        let mut spec = Vec::new();
        fft.forward(&mut x.to_vec(), &mut spec);
        (0..orders.len())
            .map(|gi| {
                let band: Vec<(f64, f64)> = spec
                    .iter()
                    .enumerate()
                    .map(|(k, c)| if k > 2 && owner(k) == Some(gi) { *c } else { (0.0, 0.0) })
                    .collect();
                ind::kurtosis(&fft.inverse(&band, x.len()))
            })
            .collect()
    };
    let now = band_kurtosis(tsa, &mut fft);
    let scores: Vec<f64> = match healthy {
        Some(h) => now.iter().zip(band_kurtosis(h, &mut fft)).map(|(a, b)| a / b).collect(),
        None => now.clone(),
    };
    let best = (0..scores.len()).max_by(|&a, &b| scores[a].total_cmp(&scores[b])).unwrap_or(0);
    let words: Vec<String> = gears
        .iter()
        .zip(&scores)
        .map(|(g, s)| format!("stage {} {} ({} teeth) {:.2}", g.stage + 1, g.gear, g.teeth, s))
        .collect();
    let what = if healthy.is_some() {
        "kurtosis of each gear's mesh band in the shaft's average over the healthy baseline's"
    } else {
        "kurtosis of each gear's mesh band in the shaft's average"
    };
    (
        gears[best],
        Some(format!(
            "the shaft carries {} gears: the impulse is in the mesh band of stage {}'s {} ({what}: {})",
            gears.len(),
            gears[best].stage + 1,
            gears[best].gear,
            words.join(", ")
        )),
    )
}
