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

use super::analysis::{Analysed, analyse_parts, tsa_indicators};
use super::verdict::{concentration, impulse_tooth};
use super::*;
use crate::model::kinematics::{Machine, Member, Ratio, SensorUnit, Stage};
use crate::report::summary::{
    MachineDiagnosis, MachineSideband, NamedHz, PlanetIndicators, PlanetaryDiagnosis, StageDiagnosis, StageGear,
    StageHarmonic, StageKind, ToothOrigin,
};
use crate::signal::planetary::{PlanetSeparation, SeparationWindow, planet_averages};

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

/// The unit name the rest of the pipeline reads (as a sidecar or `--unit` says it).
fn unit_name(u: SensorUnit) -> &'static str {
    match u {
        SensorUnit::MetrePerSecondSquared => "m/s^2",
        SensorUnit::G => "g",
        SensorUnit::MetrePerSecond => "m/s",
        SensorUnit::MillimetrePerSecond => "mm/s",
        SensorUnit::Metre => "m",
        SensorUnit::Micrometre => "um",
        SensorUnit::Volt => "V",
    }
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
            p.unit = Some(unit_name(s.unit).to_string());
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
    let stages = (0..m.stages.len()).map(|k| stage(&mut fft, &diagnosis, m, t, k, &map, &deciding, p)).collect();
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

/// Stage `k`'s gears, lines and (planetary) orders and planet averages.
#[allow(clippy::too_many_arguments)]
fn stage(
    fft: &mut Fft,
    d: &Diagnosis,
    m: &Machine,
    t: usize,
    k: usize,
    map: &AngleMap,
    deciding: &[f32],
    o: &Options,
) -> StageDiagnosis {
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
        planetary: matches!(m.stages[k], Stage::Planetary(_)).then(|| planetary(fft, d, m, t, k, map, deciding, o)),
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

/// Window of a planet's passage, in ring-tooth periods: a Hann taper over 4 teeth (McFadden 1994: a taper
/// of 2 or more teeth), at least 2 gcd(z_r, z_p) so that every planet tooth is visited.
const PLANET_WINDOW_TEETH: usize = 4;

/// A planetary stage's characteristic orders (of the tracked shaft) and its planets' averages.
#[allow(clippy::too_many_arguments)]
fn planetary(
    fft: &mut Fft,
    d: &Diagnosis,
    m: &Machine,
    t: usize,
    k: usize,
    map: &AngleMap,
    deciding: &[f32],
    o: &Options,
) -> PlanetaryDiagnosis {
    let Stage::Planetary(st) = &m.stages[k] else { unreachable!("called for planetary stages") };
    let f_t = d.shaft_hz.reference();
    let mut orders = BTreeMap::new();
    if let Some(po) = m.planetary_orders(k) {
        for (name, r) in [
            ("planet_pass", po.planet_pass),
            ("sun_fault", po.sun_fault),
            ("planet_fault", po.planet_fault),
            ("planet_fault_both", po.planet_fault_both),
            ("ring_fault", po.ring_fault),
            ("carrier", po.carrier.abs()),
            ("planet_relative", po.planet_relative.abs()),
            ("mesh", po.mesh),
        ] {
            orders.insert(name.to_string(), tracked_order(m, t, r));
        }
    }
    let frequencies_hz = f_t.map(|f| orders.iter().map(|(k, v)| (k.clone(), v * f)).collect()).unwrap_or_default();
    let (planet_averages, planet_fault_energy, no_averages) = match separate(fft, m, t, st, map, deciding, o) {
        Ok((a, e)) => (a, e, None),
        Err(why) => (Vec::new(), Vec::new(), Some(why)),
    };
    PlanetaryDiagnosis {
        planets: st.planets as usize,
        planet_angles_deg: st.planet_angles_deg.clone(),
        orders,
        frequencies_hz,
        planet_averages,
        planet_fault_energy,
        no_averages,
    }
}

/// The planets' separated averages (McFadden 1991/1994) of the deciding channel on the carrier's angle,
/// with the indicators of each (its mesh order: the planet's teeth, per planet revolution relative to the
/// carrier).
#[allow(clippy::too_many_arguments)]
fn separate(
    fft: &mut Fft,
    m: &Machine,
    t: usize,
    st: &crate::model::kinematics::PlanetaryStage,
    map: &AngleMap,
    deciding: &[f32],
    o: &Options,
) -> Result<(Vec<PlanetIndicators>, Vec<f64>), String> {
    let Member::Shaft(c) = st.carrier else {
        return Err("the carrier is fixed: the planets do not pass the sensor".into());
    };
    if st.ring != Member::Fixed {
        return Err(
            "the ring turns: a sensor on the housing does not see the planets pass at fixed carrier angles".into()
        );
    }
    let ratio = m.ratio(c, t).abs().to_f64();
    let (zr, zp) = (st.ring_teeth as usize, st.planet_teeth as usize);
    let period = map.mean_period_samples() / ratio;
    let per_tooth = (period / zr as f64).ceil().max(1.0) as usize;
    let lc = zr * per_tooth;
    let revs = tsa::revolutions_of(map, ratio);
    if revs < 2 || deciding.is_empty() {
        return Err(format!("{revs} carrier revolution(s): too few for the planets' averages"));
    }
    let mut y = vec![0.0; revs * lc];
    map.resample(deciding, 0.0, 1.0 / (lc as f64 * ratio), &mut y);
    let gcd = {
        let (mut a, mut b) = (zr, zp);
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let opts = PlanetSeparation {
        ring_teeth: zr,
        planet_teeth: zp,
        planet_angles_deg: st.planet_angles_deg.clone(),
        samples_per_rev: lc,
        window_teeth: PLANET_WINDOW_TEETH.max(2 * gcd),
        window: SeparationWindow::Hann,
    };
    let energy = gated_fault_energy(&y, lc, per_tooth, zr as f64 / zp as f64, &st.planet_angles_deg);
    let averages = planet_averages(&y, &opts).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for (i, a) in averages.into_iter().enumerate() {
        let Some(samples) = a.samples else {
            return Err(format!(
                "planet {} was not seen at every tooth in {revs} carrier revolutions: give a longer recording",
                i + 1
            ));
        };
        let (indicators, dec) = tsa_indicators(fft, &samples, zp, &Default::default(), o.shaft_orders);
        out.push(PlanetIndicators { planet: i + 1, passes: a.passes, indicators, samples, difference: dec.difference });
    }
    Ok((out, energy))
}

/// Half-width of the gate around a planet's passage, degrees of carrier angle: the sensor's view of a
/// planet falls off within a few tens of degrees, and the planets stand at least 100 degrees apart.
const PLANET_GATE_DEG: f64 = 20.0;

/// [`PlanetaryDiagnosis::planet_fault_energy`](crate::report::summary::PlanetaryDiagnosis) of each planet:
/// `y` the signal on the carrier angle (`lc` samples per revolution, sample 0 at angle 0, `p` samples per
/// ring tooth), `q` the planet-fault order of the carrier (z_r / z_p with the ring fixed).
///
/// ```text
/// r(i)   = y(i) - y(i - p)                       tooth-to-tooth difference (r = 0 for i < p)
/// s(i)   = (r(i)^2 - mean r^2) g_k(i)            g_k a Hann gate of +-PLANET_GATE_DEG around planet k's passage
/// c_km   = sum_i s(i) exp(-j m q theta_i)        theta_i = 2 pi i / lc, cumulative; m = 1..3
/// E_k    = sum_m |c_km|^2 / n^2                  n = samples of y
/// ```
/// Why the difference: the meshing vibration repeats from one tooth to the next (every planet's ring
/// mesh and every sun mesh advance one tooth per ring-tooth period of carrier angle), so the difference
/// removes it locally, whatever the speed fluctuation (it spans one tooth, not a revolution), and keeps a
/// faulty tooth's burst. Squaring the raw signal instead mixes the burst with the meshing vibration it
/// falls on: a planet's fault reaches the sensor through its sun mesh at every carrier angle too, and
/// that copy, multiplied by the other planets' meshing while they pass the sensor, lifted another
/// planet's gate more than the faulty planet's own (whose burst and cross term partly cancel: a crack
/// lowers its tooth's vibration). Regression: a crack on planet 2's tooth 7 was named planet 3 on the
/// independent generator's stage in 4 of 4 seeds (tests/machine_diagnose.rs).
fn gated_fault_energy(y: &[f64], lc: usize, p: usize, q: f64, angles_deg: &[f64]) -> Vec<f64> {
    let diff = |i: usize| if i >= p { y[i] - y[i - p] } else { 0.0 };
    let n = y.len().max(1) as f64;
    let mean = (0..y.len()).map(|i| diff(i) * diff(i)).sum::<f64>() / n;
    let half = (PLANET_GATE_DEG / 360.0 * lc as f64).max(1.0);
    angles_deg
        .iter()
        .map(|psi| {
            let centre = psi / 360.0 * lc as f64;
            let mut sums = [(0.0f64, 0.0f64); 3];
            for i in 0..y.len() {
                // distance from the passage, samples, within one revolution
                let d = ((i % lc) as f64 - centre + lc as f64 / 2.0).rem_euclid(lc as f64) - lc as f64 / 2.0;
                if d.abs() >= half {
                    continue;
                }
                let g = 0.5 + 0.5 * (std::f64::consts::PI * d / half).cos();
                let v = diff(i);
                let s = (v * v - mean) * g;
                let theta = 2.0 * std::f64::consts::PI * i as f64 / lc as f64;
                for (m, acc) in sums.iter_mut().enumerate() {
                    let a = (m + 1) as f64 * q * theta;
                    acc.0 += s * a.cos();
                    acc.1 -= s * a.sin();
                }
            }
            sums.iter().map(|(re, im)| (re * re + im * im) / (n * n)).sum()
        })
        .collect()
}

/// Growth of a planet's gated planet-fault energy over the healthy baseline's at which the planet is named
/// (and the verdict made suspect), when it is also [`PLANET_LEAD`] times every other planet's growth; at
/// [`PLANET_FAULTY_GROWTH`] faulty. Engineering choices checked on the independent generator's planetary
/// stage (tests/machine_diagnose.rs): healthy recordings of 5 seeds against a healthy baseline grow by at
/// most 1.5 on any planet; 50 % cracks on teeth 3, 7, 13 and 20 of each planet (several seeds) by 8-80 on
/// that planet and 4-55 times more than on any other.
pub const PLANET_SUSPECT_GROWTH: f64 = 4.0;
/// See [`PLANET_SUSPECT_GROWTH`].
pub const PLANET_FAULTY_GROWTH: f64 = 8.0;
/// See [`PLANET_SUSPECT_GROWTH`].
pub const PLANET_LEAD: f64 = 1.5;

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
    // a tooth only when the shaft's own indicators moved (a verdict from the envelope alone names the gear;
    // without a baseline there are no scores and the indicators decided)
    let moved = d.scores.is_empty()
        || d.scores.iter().any(|s| s.gear == Shaft::Named(name) && s.decides && s.spreads >= s.suspect_at);
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

/// Names a planet whose gated planet-fault energy grew over the healthy baseline's (see
/// [`PLANET_SUSPECT_GROWTH`]); returns whether it did. Without a baseline's planets nothing is named here
/// (the planets' own averages and energies are reported).
fn name_planet(d: &mut Diagnosis, baseline: Option<&[crate::report::summary::PlanetBaseline]>) -> bool {
    let (Some(md), Some(b)) = (&d.machine, baseline) else { return false };
    let mut best: Option<(usize, usize, f64, f64)> = None; // stage, planet, growth, lead over the others
    for s in &md.stages {
        let (Some(p), Some(bp)) = (&s.planetary, b.iter().find(|x| x.stage == s.stage)) else { continue };
        if p.planet_fault_energy.len() != bp.planet_fault_energy.len() || p.planet_fault_energy.len() < 2 {
            continue;
        }
        let growth: Vec<f64> = p
            .planet_fault_energy
            .iter()
            .zip(&bp.planet_fault_energy)
            .map(|(a, b)| a / b.max(f64::MIN_POSITIVE))
            .collect();
        for (i, &g) in growth.iter().enumerate() {
            let others = growth.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, v)| *v).fold(0.0, f64::max);
            let lead = g / others.max(f64::MIN_POSITIVE);
            if g.is_finite() && best.is_none_or(|b| g > b.2) {
                best = Some((s.stage, i + 1, g, lead));
            }
        }
    }
    let Some((stage, planet, growth, lead)) = best.filter(|b| b.2 >= PLANET_SUSPECT_GROWTH && b.3 >= PLANET_LEAD)
    else {
        return false;
    };
    let state = if growth >= PLANET_FAULTY_GROWTH { VerdictState::Faulty } else { VerdictState::Suspect };
    let reason = format!(
        "stage {stage} planet {planet}: the planet-fault order family of the squared tooth-to-tooth difference while it passes the sensor grew {} times over the healthy baseline's ({} times any other planet's growth; suspect from {PLANET_SUSPECT_GROWTH}, faulty from {PLANET_FAULTY_GROWTH}): a local fault on that planet",
        crate::report::format::num(growth),
        crate::report::format::num(lead)
    );
    let v = &mut d.verdict;
    if v.state > VerdictState::Healthy {
        // what the shafts' averages showed is the planet's fault seen through them
        let was = std::mem::take(&mut v.reasons);
        v.cross_talk.extend(
            was.into_iter()
                .take(2)
                .map(|r| format!("the shafts' averages moved too ({r}): the planet's fault seen through them")),
        );
    }
    v.state = v.state.max(state);
    v.reasons.insert(0, reason);
    v.gear = VerdictGear::Planet;
    v.stage = Some(stage);
    v.planet = Some(planet);
    v.shaft = None;
    v.tooth = None;
    v.tooth_origin = None;
    true
}
