//! The statistical baseline: healthy recordings of the same machine, cut into blocks of whole revolutions;
//! each indicator's distribution over the blocks (median and robust spread) is the reference, and a
//! recording is scored by how many spreads the median of its own blocks lies above that centre.
//!
//! Scores: s = (value - centre) / spread with centre = median of the baseline blocks and spread =
//! max(1.4826 MAD, 5 % of |centre|), on the logarithm of the moment and energy ratios (see [`Scale`]). For Gaussian block values 1.4826 MAD estimates the standard deviation;
//! the 5 % floor keeps a baseline of near-identical blocks (a noise-free simulation) from turning every
//! rounding-level change into a detection. Limits are one-sided prediction limits for a new block from m
//! baseline blocks at a stated false-alarm rate per indicator (1e-3 suspect, 1e-6 faulty):
//! t_{m-1}(1 - alpha) sqrt(1 + 1/m) spreads, Student's t because the spread itself is estimated from m
//! blocks (m = 5 gives 8.0 spreads for 1e-3, m = 30 gives 3.5, many blocks 3.09). A median over several
//! blocks scatters less than one block, so the real rate is lower still.
//!
//! Files that differ among themselves more than their blocks do (loads the others were not recorded at)
//! widen the spread: a healthy file's median is a healthy recording's, so the suspect limit lies at least
//! s_m = 1.2533 spread / sqrt(n) (the scatter of a median of the recording's n blocks) times the suspect
//! quantile above the highest file's median h: spread' = max(spread, (h - centre) / t + s_m), t the
//! suspect limit in spreads. On the real rig a profile of the 0, 60, 80 and 90 % loads called the healthy
//! 10 % file FAULTY at 4.3 spreads (its ER sits with the 0 % file's); a broken tooth stays 20 spreads up.

use super::{Given, JobError};
use crate::Error;
use crate::report::summary::{
    Block, Diagnosis, GearIndicators, Indicator, LocalChange, LongScore, Scale, Score, Shaft, Tracking,
};
use crate::signal::spectrum::Fft;
use crate::signal::tsa_change::{self, OrderSpectrum, Scatter, SidebandChange};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Standard normal quantile of the suspect limit: one-sided false-alarm probability 1e-3 per indicator.
pub const SUSPECT_Z: f64 = 3.090_232;
/// Standard normal quantile of the faulty limit: one-sided false-alarm probability 1e-6 per indicator.
pub const FAULTY_Z: f64 = 4.753_424;

/// Student-t quantile with `nu` degrees of freedom at the normal quantile `z` (Cornish-Fisher expansion to
/// 1 / nu^4; Abramowitz and Stegun 26.7.5), within 1 % of the exact value for nu >= 3 at these tails.
pub fn student_t(z: f64, nu: f64) -> f64 {
    let z2 = z * z;
    let g1 = (z2 + 1.0) * z / 4.0;
    let g2 = ((5.0 * z2 + 16.0) * z2 + 3.0) * z / 96.0;
    let g3 = (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) * z / 384.0;
    let g4 = ((((79.0 * z2 + 776.0) * z2 + 1482.0) * z2 - 1920.0) * z2 - 945.0) * z / 92160.0;
    z + g1 / nu + g2 / nu.powi(2) + g3 / nu.powi(3) + g4 / nu.powi(4)
}

/// Suspect and faulty limits in spreads for a baseline of `m` blocks (prediction limits for one new block).
pub fn limits(m: usize) -> (f64, f64) {
    let m = m.max(MIN_BASELINE_BLOCKS) as f64;
    let inflate = (1.0 + 1.0 / m).sqrt();
    (student_t(SUSPECT_Z, m - 1.0) * inflate, student_t(FAULTY_Z, m - 1.0) * inflate)
}
/// Scatter of the median of n normal values over one value's, times sqrt(n): sqrt(pi / 2).
const MEDIAN_SCATTER: f64 = 1.253_314;
/// Fewest baseline blocks per gear and channel for a distribution.
pub const MIN_BASELINE_BLOCKS: usize = 4;
/// Relative floor of the spread (5 % of the centre).
const SPREAD_FLOOR: f64 = 0.05;
/// An amplitude indicator (SI) below this fraction of the gear's TSA RMS, in the baseline and now, is
/// noise: it never decides.
const NEAR_ZERO_OF_RMS: f64 = 1e-3;
/// Least spread of the spectral change, dB: its relative floor (5 % of a centre) vanishes on a noise-free
/// simulation, whose blocks differ by rounding alone (8.8e-15 dB), so the same samples as their own
/// baseline scored 13.8 spreads at 1.5e-14 dB and were called FAULTY; an RMS change of the log order
/// spectrum of a tenth of a dB is no change an engineer could see (healthy recordings of real and
/// generated machines spread by 0.2-0.3 dB from block to block, faults move it by several dB).
const SPECTRAL_CHANGE_LEAST_SPREAD_DB: f64 = 0.1;
/// Dynamic range of the log spectra of the spectral-change indicator, dB (weaker orders are clipped there).
const SPECTRUM_RANGE_DB: f64 = 60.0;

/// How far a recording's local change must rise over the largest of the baseline files' (each against the
/// others) to count as evidence. Healthy generated recordings of four machines of another physics (three
/// per machine, each against its two siblings) stand at most 2.2x over their siblings' largest (1.9x on the
/// tachometer's angle); their 10 % cracks 1.9-27x on the tachometer's angle (six of eight over 5x), 25-50 %
/// cracks and spalls far more. Two files give a thin picture of how healthy recordings differ, so the
/// limit keeps a margin over what they showed.
pub const LOCAL_RISE: f64 = 2.5;
/// How far a recording's sideband growth must rise over the largest of the baseline files' (each against
/// the others), and the least growth that counts: healthy generated recordings of four machines reach 6.9
/// (against siblings that show 5.4 among themselves), 3.2x their siblings' where those are small; their
/// eccentric gears 7.7-91, their worn gears up to 51 (and under 8 on the other gear of the pair).
pub const SIDEBAND_RISE: f64 = 3.0;
/// See [`SIDEBAND_RISE`].
pub const SIDEBAND_MIN: f64 = 8.0;
/// A second, steeper path for the sideband growth where the baseline's files agree closely: growth over
/// this many times theirs (and over [`SIDEBAND_LEAST`]) counts too. Where a gear's mesh sidebands are
/// real lines (the hold-out generator's, tests/holdout: pitch and profile errors of several um) healthy
/// recordings grow 0.03-2.3 against two siblings, at most 3.8 times what the siblings show among
/// themselves (27 recordings, both gears, with the nameplate speed and the tachometer), and eccentric
/// pinions of 12-25 um 0.28-1.0, 4.3-7.2 times: [`SIDEBAND_MIN`] alone misses every one. On the first
/// generator one healthy wheel of 18 reaches 12 times its siblings' 0.15 on the tachometer's angle (1.6
/// times on the mesh's) and is then suspect; its eccentric gears stand at 55-530 times.
pub const SIDEBAND_RISE_STEEP: f64 = 4.5;
/// See [`SIDEBAND_RISE_STEEP`]: the least growth (a quarter of the baseline's sideband energy, 1 dB) that
/// counts on that path.
pub const SIDEBAND_LEAST: f64 = 0.25;

/// The sideband growth from which a recording's counts as evidence, given the largest growth of the
/// baseline's files among themselves (`healthy`, NaN from one file): the lower of
/// max([`SIDEBAND_RISE`] healthy, [`SIDEBAND_MIN`]) and max([`SIDEBAND_RISE_STEEP`] healthy,
/// [`SIDEBAND_LEAST`]); from one file the first alone.
pub fn sidebands_limit(healthy: f64) -> f64 {
    let first = (SIDEBAND_RISE * healthy).max(SIDEBAND_MIN);
    if healthy.is_finite() { first.min((SIDEBAND_RISE_STEEP * healthy).max(SIDEBAND_LEAST)) } else { first }
}

/// Factor on what the two halves of a single healthy file show against each other (local change,
/// sideband growth, pattern change), taken for how far separate healthy recordings differ: the halves of one
/// recording share its hour, temperature and load, so they differ less than recordings made apart. On the
/// real SpectraQuest rig (`data/realdata`, 88-106 k samples) the halves of one healthy file, each judged
/// against the other as a single-file baseline, reach 1.5 times the limit their quarters give (local change
/// 15.6 against 10.2 at 0 % load, channel 3); 2 keeps them healthy with a margin. On the hold-out
/// generator's machines (tests/holdout) a single healthy file then flags 62 of 72 faults with the nameplate
/// speed or the tachometer (53 without its halves), and no healthy sibling more than before.
const ONE_FILE_MARGIN: f64 = 2.0;

/// Factor on the noise a comparison carries when the sideband growth's limit is set from a single file's
/// halves ([`SidebandNoise`]): the halves share one recording's speed and load course and cannot show how
/// separate recordings differ beyond their noise. Set between two groups of the hold-out generator
/// (tests/holdout) with the nameplate speed and one sibling: m1's healthy siblings differ at the wheel's
/// sidebands by 4.5 times their noise where its halves show nothing beyond theirs, while the eccentric and
/// worn gears that one sibling flags stand at 5.8-24 times theirs. 7/6 (5.25 times the noise on the steep
/// path's 4.5) leaves the healthy wheel at 0.85 of its limit and those faults at 1.1-1.5 times theirs;
/// 4/3 lost the worn m4 wheel, 1 left the healthy wheel at 0.99.
const ONE_FILE_NOISE_MARGIN: f64 = 7.0 / 6.0;

/// Least local change that counts at all: over z pitches of noise alone the largest pitch holds 1.5-3
/// times the median's energy.
pub const LOCAL_MIN: f64 = 3.0;

/// Smallest normalised correlation of a recording's mean residual with the baseline's for the local
/// change to be scored: below it the two averages do not line up (another gear, or a residual of noise
/// alone), and their difference would read as a change everywhere.
pub const MIN_ALIGNMENT: f64 = 0.2;

/// A distribution over blocks.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
struct Stat {
    centre: f64,
    spread: f64,
    min: f64,
    max: f64,
    count: usize,
    scale: Scale,
    /// The highest of the baseline files' own medians (on the scale), from two files or more: how far a
    /// healthy recording's median reached (absent from one file and in profiles written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    highest_file: Option<f64>,
    /// From a single file: how far a neighbouring load may move a healthy recording's median
    /// ([`one_file::allowance`], on the scale), which the file's blocks cannot show (absent from two files
    /// or more, and in profiles written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    load_allowance: Option<f64>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl Stat {
    /// The distribution of `values` on `scale` (non-finite values, and non-positive ones on the log scale,
    /// are left out).
    fn of(values: &[f64], scale: Scale) -> Self {
        let mut v: Vec<f64> =
            values.iter().copied().filter(|x| x.is_finite() && (scale == Scale::Linear || *x > 0.0)).collect();
        v.sort_by(f64::total_cmp);
        let (min, max) = (v.first().copied().unwrap_or(f64::NAN), v.last().copied().unwrap_or(f64::NAN));
        let mut t: Vec<f64> = v.iter().map(|&x| scale.to(x)).collect();
        let centre = median(&mut t);
        let mut dev: Vec<f64> = t.iter().map(|x| (x - centre).abs()).collect();
        let floor = match scale {
            Scale::Linear => SPREAD_FLOOR * centre.abs(),
            Scale::Log => (1.0 + SPREAD_FLOOR).ln(),
        };
        Self {
            centre,
            spread: (1.4826 * median(&mut dev)).max(floor).max(f64::MIN_POSITIVE),
            min,
            max,
            count: v.len(),
            scale,
            highest_file: None,
            load_allowance: None,
        }
    }

    /// This distribution with the highest of `files`' medians (each file's values; from two files on).
    fn with_files(self, files: &[Vec<f64>]) -> Self {
        let medians = files.iter().map(|f| {
            let mut t: Vec<f64> = f
                .iter()
                .copied()
                .filter(|x| x.is_finite() && (self.scale == Scale::Linear || *x > 0.0))
                .map(|x| self.scale.to(x))
                .collect();
            median(&mut t)
        });
        let highest = medians.filter(|m| m.is_finite()).fold(f64::NAN, f64::max);
        Self { highest_file: (files.len() >= 2 && highest.is_finite()).then_some(highest), ..self }
    }

    /// The spread a recording's median of `blocks` blocks is scored in: the blocks' spread, widened when
    /// the baseline's files differ among themselves more than their blocks do, so that the suspect limit
    /// (`suspect_at` spreads) lies at least `suspect_at` of the median's own scatter above the highest
    /// file's median (a median of n values scatters by 1.2533 / sqrt(n) of one value's spread). Returns
    /// the spread and whether the files widened it.
    fn scoring_spread(&self, blocks: usize, suspect_at: f64) -> (f64, bool) {
        let Some(highest) = self.highest_file else { return (self.spread, false) };
        let of_median = MEDIAN_SCATTER * self.spread / (blocks.max(1) as f64).sqrt();
        let files = (highest - self.centre) / suspect_at + of_median;
        if files > self.spread { (files, true) } else { (self.spread, false) }
    }

    /// This distribution with its spread at least `least` (in the scale's units).
    fn with_least_spread(self, least: f64) -> Self {
        Self { spread: self.spread.max(least), ..self }
    }
}

/// A [`Scale`] as a map to the scored value and back.
trait Transform {
    fn to(self, x: f64) -> f64;
    fn from(self, x: f64) -> f64;
}

impl Transform for Scale {
    fn to(self, x: f64) -> f64 {
        match self {
            Self::Linear => x,
            Self::Log => x.ln(),
        }
    }
    fn from(self, x: f64) -> f64 {
        match self {
            Self::Linear => x,
            Self::Log => x.exp(),
        }
    }
}

/// The reference of one gear on one channel.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct GearReference {
    stats: BTreeMap<Indicator, Stat>,
    /// Median residual variance of the blocks (NA4*'s denominator).
    residual_var: f64,
    /// Mean log amplitude spectrum of the blocks, dB, and its floor.
    log_spectrum: Vec<f64>,
    floor: f64,
    /// Median TSA RMS of the blocks (scale for near-zero amplitudes).
    rms: f64,
    /// Mean complex order spectrum (re, im) of the baseline files' residuals, each shifted onto the first
    /// file's angle origin: the local-change indicator's reference (empty in profiles written before it,
    /// which then do not score it).
    #[serde(default)]
    residual_mean: Vec<(f64, f64)>,
    /// The local change of each baseline file's mean residual against the other files': how far healthy
    /// recordings of the gear differ locally (empty from one file).
    #[serde(default)]
    local_healthy: Vec<f64>,
    /// The sideband growth of each baseline file against the other files'.
    #[serde(default)]
    sidebands_healthy: Vec<f64>,
    /// The same less what the files' noise explains (see [`SidebandNoise`]); empty in profiles written
    /// before it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    sidebands_beyond_noise: Vec<f64>,
    /// The noise energy `residual_mean` holds at the first-order sidebands (the files' block scatter there,
    /// each file's over its blocks, over the files squared); absent in profiles written before it, which
    /// then score the sideband growth without a noise allowance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sidebands_noise: Option<f64>,
    /// The pattern change ([`tsa_change::pattern_change`]) of each baseline file against the other files'.
    #[serde(default)]
    pattern_healthy: Vec<f64>,
    /// The noise each of those comparisons carried, as a share of the baseline's energy at the pattern's
    /// orders (a half's over 2); empty in profiles written before it, which then score the pattern change
    /// without a noise allowance (see `local::at_baseline_noise`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pattern_noise: Vec<f64>,
    /// Each baseline file's whole-record average ([`long`]); empty in profiles written before it, which
    /// then do not score the whole record.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    long_files: Vec<LongAverage>,
}

/// The statistical baseline of every gear and channel.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(into = "ReferenceFile", try_from = "ReferenceFile")]
pub struct Reference {
    gears: BTreeMap<(Shaft, usize), GearReference>,
    /// Files pooled.
    pub files: usize,
    /// The weakest mesh line the baseline files' angles were followed on (dB over its band), when every
    /// file was tracked on its mesh phase: how clean an angle the baseline's averages rest on.
    pub tracked_line_db: Option<f64>,
    /// The files were stated to be recorded at the recording's load ([`BaselineLoad::Same`]; never stored).
    same_load: bool,
}

/// A [`Reference`] as stored in a profile: one entry per gear and channel (JSON has no tuple keys).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ReferenceFile {
    files: usize,
    gears: Vec<GearEntry>,
    /// [`Reference::tracked_line_db`] (absent in profiles written before it, and when the baseline was
    /// not tracked on its mesh phase).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tracked_line_db: Option<f64>,
}

/// One gear and channel of a stored reference.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GearEntry {
    gear: Shaft,
    channel: usize,
    #[serde(flatten)]
    reference: GearReference,
}

impl From<Reference> for ReferenceFile {
    fn from(r: Reference) -> Self {
        // a distribution without a finite value cannot score anything (and JSON has no NaN): left out
        let gears = r
            .gears
            .into_iter()
            .map(|((gear, channel), mut reference)| {
                reference.stats.retain(|_, s| s.centre.is_finite() && s.min.is_finite() && s.max.is_finite());
                GearEntry { gear, channel, reference }
            })
            .collect();
        Self { files: r.files, gears, tracked_line_db: r.tracked_line_db.filter(|v| v.is_finite()) }
    }
}

impl TryFrom<ReferenceFile> for Reference {
    type Error = String;
    fn try_from(f: ReferenceFile) -> Result<Self, String> {
        let mut gears = BTreeMap::new();
        for g in f.gears {
            let ok = g.reference.log_spectrum.iter().all(|v| v.is_finite())
                && g.reference.residual_mean.iter().all(|c| c.0.is_finite() && c.1.is_finite())
                && g.reference.local_healthy.iter().all(|v| v.is_finite() && *v > 0.0)
                && g.reference.sidebands_noise.is_none_or(|v| v.is_finite() && v >= 0.0)
                && g.reference.sidebands_beyond_noise.iter().all(|v| v.is_finite() && *v >= 0.0)
                && g.reference.stats.values().all(|s| s.spread > 0.0 && s.centre.is_finite() && s.count > 0)
                && g.reference.residual_var > 0.0;
            if !ok {
                return Err(format!(
                    "the {} (channel {}) has a distribution that is not finite or has no spread",
                    g.gear, g.channel
                ));
            }
            if gears.insert((g.gear, g.channel), g.reference).is_some() {
                return Err(format!("the {} (channel {}) is listed twice", g.gear, g.channel));
            }
        }
        if gears.is_empty() {
            return Err("no gear".into());
        }
        Ok(Self { gears, files: f.files, tracked_line_db: f.tracked_line_db, same_load: false })
    }
}

fn log_spectrum(a: &[f64], floor: f64) -> Vec<f64> {
    a.iter().skip(1).map(|v| 20.0 * v.max(floor).log10()).collect()
}

fn rms_db(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()).max(1);
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt()
}

/// Per-block values of the deciding indicators that need the reference (NA4*, spectral change).
fn derived(block: &Block, residual_var: f64, log_ref: &[f64], floor: f64) -> (f64, f64) {
    let m4 = block.indicators.get(&Indicator::ResidualM4).copied().unwrap_or(f64::NAN);
    let len = log_ref.len() + 1;
    let a = &block.amplitudes[..len.min(block.amplitudes.len())];
    (m4 / (residual_var * residual_var), rms_db(&log_spectrum(a, floor), log_ref))
}

fn value(block: &Block, key: Indicator) -> f64 {
    block.indicators.get(&key).copied().unwrap_or(f64::NAN)
}

/// Builds the reference from healthy recordings (their blocks pooled per gear and channel).
///
/// # Errors
/// A gear and channel with fewer than [`MIN_BASELINE_BLOCKS`] blocks over all baseline files.
pub fn build(baselines: &[Diagnosis], block_revs: usize) -> Result<Reference, Error> {
    let mut pooled: BTreeMap<(Shaft, usize), Vec<&Block>> = BTreeMap::new();
    let mut per_file: BTreeMap<(Shaft, usize), Vec<Vec<&Block>>> = BTreeMap::new();
    let mut revs: BTreeMap<(Shaft, usize), usize> = BTreeMap::new();
    let mut teeth: BTreeMap<(Shaft, usize), usize> = BTreeMap::new();
    let mut long: BTreeMap<(Shaft, usize), Vec<LongAverage>> = BTreeMap::new();
    for d in baselines {
        for g in &d.gears {
            let key = (g.gear.baseline_key(), g.channel);
            long.entry(key).or_default().push(LongAverage::of(g));
            pooled.entry(key).or_default().extend(&g.blocks);
            per_file.entry(key).or_default().push(g.blocks.iter().collect());
            *revs.entry(key).or_default() += g.revolutions;
            teeth.insert(key, g.mesh_order);
        }
    }
    let mut fft = Fft::new();
    let mut gears = BTreeMap::new();
    for (key, blocks) in pooled {
        if blocks.len() < MIN_BASELINE_BLOCKS {
            return Err(JobError::Value {
                what: Given::Baseline,
                message: format!(
                    "{} revolutions of the {} (channel {}) give {} block(s) of {block_revs}; the statistical baseline needs at least {MIN_BASELINE_BLOCKS}: give a longer healthy recording, several, or fewer revolutions per block",
                    revs[&key],
                    key.0,
                    key.1,
                    blocks.len()
                ),
            }
            .into());
        }
        let len = blocks.iter().map(|b| b.amplitudes.len()).min().unwrap_or(0);
        let mean_amp: Vec<f64> =
            (0..len).map(|k| blocks.iter().map(|b| b.amplitudes[k]).sum::<f64>() / blocks.len() as f64).collect();
        let floor = mean_amp.iter().skip(1).copied().fold(0.0, f64::max) * 10f64.powf(-SPECTRUM_RANGE_DB / 20.0);
        let floor = floor.max(f64::MIN_POSITIVE);
        let logs: Vec<Vec<f64>> = blocks.iter().map(|b| log_spectrum(&b.amplitudes[..len], floor)).collect();
        let log_ref: Vec<f64> =
            (0..len.saturating_sub(1)).map(|k| logs.iter().map(|l| l[k]).sum::<f64>() / logs.len() as f64).collect();
        let residual_var = median(&mut blocks.iter().map(|b| value(b, Indicator::ResidualM2)).collect::<Vec<_>>());
        // each baseline block against the mean of the others (leave one out): against a mean that holds the
        // block itself its distance would read low by about sqrt((m - 1) / (m + 1)) against a new block's
        let m = logs.len() as f64;
        let leave_one_out: Vec<f64> = logs
            .iter()
            .map(|l| {
                let others: Vec<f64> = log_ref.iter().zip(l).map(|(r, x)| (m * r - x) / (m - 1.0)).collect();
                rms_db(l, &others)
            })
            .collect();
        let LocalReference {
            residual_mean,
            local_healthy,
            sidebands_healthy,
            sidebands_beyond_noise,
            sidebands_noise,
            pattern_healthy,
            pattern_noise,
        } = local_reference(&mut fft, &per_file[&key], teeth[&key]);
        let mut stats = BTreeMap::new();
        for k in Indicator::DECIDING {
            let values: Vec<f64> = match k {
                Indicator::Na4Star => blocks.iter().map(|b| derived(b, residual_var, &log_ref, floor).0).collect(),
                Indicator::SpectralChange => leave_one_out.clone(),
                _ => blocks.iter().map(|b| value(b, k)).collect(),
            };
            let stat = Stat::of(&values, k.scale())
                .with_files(&by_file(&values, &per_file[&key]))
                .with_one_file(per_file[&key].len(), one_file::allowance(k));
            let least = if k == Indicator::SpectralChange { SPECTRAL_CHANGE_LEAST_SPREAD_DB } else { 0.0 };
            stats.insert(k, stat.with_least_spread(least));
        }
        let rms = median(&mut blocks.iter().map(|b| value(b, Indicator::Rms)).collect::<Vec<_>>());
        gears.insert(
            key,
            GearReference {
                stats,
                residual_var,
                log_spectrum: log_ref,
                floor,
                rms,
                residual_mean,
                local_healthy,
                sidebands_healthy,
                sidebands_beyond_noise,
                sidebands_noise,
                pattern_healthy,
                pattern_noise,
                long_files: long.remove(&key).unwrap_or_default(),
            },
        );
    }
    let lines: Vec<Option<f64>> = baselines
        .iter()
        .map(|d| d.speed_profile.line_snr_db.filter(|_| d.speed_profile.tracking == Tracking::MeshPhase))
        .collect();
    let tracked_line_db =
        lines.iter().copied().collect::<Option<Vec<f64>>>().and_then(|v| v.into_iter().reduce(f64::min));
    Ok(Reference { gears, files: baselines.len(), tracked_line_db, same_load: false })
}

/// `values` (one per pooled block, the files' blocks one after the other) cut back into the files.
fn by_file(values: &[f64], files: &[Vec<&Block>]) -> Vec<Vec<f64>> {
    let mut rest = values;
    files
        .iter()
        .map(|f| {
            let (own, tail) = rest.split_at(f.len().min(rest.len()));
            rest = tail;
            own.to_vec()
        })
        .collect()
}

fn slices(v: &[OrderSpectrum]) -> Vec<&[(f64, f64)]> {
    v.iter().map(|s| s.as_slice()).collect()
}

/// The residual spectra of the blocks that kept one.
fn spectra(blocks: &[&Block]) -> Vec<OrderSpectrum> {
    blocks.iter().map(|b| b.residual_spectrum.clone()).filter(|s| s.len() > 1).collect()
}

impl Reference {
    /// Whether the reference holds the gear and channel of `g`.
    pub fn covers(&self, g: &GearIndicators) -> bool {
        self.gears.contains_key(&(g.gear.baseline_key(), g.channel))
    }

    /// The local change of gear `g` against this baseline (`None` when the baseline lacks the gear or holds no
    /// residual, as profiles written before it, or when the averages do not line up; `Some(Err(SameData))` when
    /// the recording's average is the baseline's own data). `shared_step`: z / gcd(z, z_other) of a pair whose
    /// teeth share a factor, else 1.
    pub fn local_change(&self, g: &GearIndicators, shared_step: usize) -> Option<Result<LocalChange, SameData>> {
        let r = self.gears.get(&(g.gear.baseline_key(), g.channel))?;
        local_change_of(&mut Fft::new(), g, r, (self.files == 1, self.same_load), shared_step)
    }
}

mod fit;
mod local;
mod long;
mod one_file;
mod score;
pub use fit::{MESH_LOST_DB, SYNCHRONOUS_LOST_SHARE, mesh_change_db, mesh_lost, synchronous_lost};
pub use local::SameData;
use local::{LocalReference, local_change_of, local_reference};
use long::LongAverage;
pub use one_file::BaselineLoad;
pub use score::{score_long, score_one};

#[cfg(test)]
mod tests;
