//! The change of a gear's average against the baseline's: the baseline files' mean residual and how far
//! each file differs from the others ([`local_reference`]), and a recording's local change, sideband growth
//! (with the noise its comparison carries) and pattern change against them ([`local_change_of`]).

use super::*;

/// The local-change reference of one gear and channel of `z` teeth from the baseline's blocks grouped by
/// file: the mean residual spectrum of the files, each shifted onto their common origin, and the local
/// change of each file's mean against the mean of the other files (a new recording differs from the
/// baseline by its load, speed and noise, as the files differ among themselves). A single file of at
/// least 2 [`MIN_BASELINE_BLOCKS`] blocks stands in for two by its halves, whose figures are taken
/// [`ONE_FILE_MARGIN`] times over.
pub(super) fn local_reference(fft: &mut Fft, files: &[Vec<&Block>], z: usize) -> LocalReference {
    let mut files: Vec<Vec<OrderSpectrum>> = files.iter().map(|f| spectra(f)).filter(|s| !s.is_empty()).collect();
    let halves = files.len() == 1 && files[0].len() >= 2 * MIN_BASELINE_BLOCKS;
    if halves {
        let half = files[0].len() / 2;
        let second = files[0].split_off(half);
        files.push(second);
    }
    let margin = if halves { ONE_FILE_MARGIN } else { 1.0 };
    let mut out = LocalReference::default();
    if files.is_empty() {
        return out;
    }
    // every file's blocks shifted onto the first file's mean, then onto the mean of them all: block by
    // block, so that a tracked angle's slow wander between blocks does not smear the high orders
    let mut reference = tsa_change::mean(&slices(&files[0]));
    let mut aligned: Vec<OrderSpectrum> = Vec::new();
    let mut noise: Vec<Option<f64>> = Vec::new();
    let mut pattern_noise: Vec<Option<f64>> = Vec::new();
    for _ in 0..2 {
        let means: Vec<Aligned> = files.iter().map(|f| aligned_blocks(f, &reference, z)).collect();
        noise = means.iter().map(|a| a.sidebands.map(Scatter::of_mean)).collect();
        pattern_noise = means.iter().map(|a| a.pattern.map(Scatter::of_mean)).collect();
        aligned = means.into_iter().map(|a| a.mean).collect();
        reference = tsa_change::mean(&slices(&aligned));
    }
    let files_noise: Option<Vec<f64>> = noise.iter().copied().collect();
    for f in 0..aligned.len() {
        if aligned.len() < 2 {
            break;
        }
        let others: Vec<&[(f64, f64)]> =
            aligned.iter().enumerate().filter(|(g, _)| *g != f).map(|(_, a)| a.as_slice()).collect();
        let r = tsa_change::mean(&others);
        out.local_healthy.extend(tsa_change::concentration(fft, &aligned[f], &r, z).map(|c| margin * c.ratio));
        if let Some(c) = tsa_change::sideband_change(&aligned[f], &r, z) {
            out.sidebands_healthy.push(margin * c.change / c.own);
            if let Some(files) = &files_noise {
                out.sidebands_beyond_noise.push(margin * SidebandNoise::between(files, f).beyond(c));
            }
        }
        if let Some(p) = tsa_change::pattern_parts(&aligned[f], &r, z) {
            out.pattern_healthy.push(margin * p.change / p.own);
            // a half holds twice the noise of a whole file of the same length
            if let Some(n) = pattern_noise[f] {
                out.pattern_noise.push(n / p.own / if halves { 2.0 } else { 1.0 });
            }
        }
    }
    out.sidebands_noise = files_noise.map(|n| n.iter().sum::<f64>() / (n.len() * n.len()) as f64);
    out.residual_mean = reference;
    out
}

/// The noise at the first-order sidebands of one comparison `x - s r` ([`tsa_change::sideband_change`]):
/// the noise energy of `x`'s mean and of `r`'s (each a block scatter over its block count), so that what a
/// healthy recording's growth holds beyond its noise can be told from what the noise alone puts there. The
/// halves of one file hold twice the noise a whole recording does, and a long recording less than a short
/// one: taken out, the healthy figure keeps the change between recordings and the noise is allowed for the
/// recording under test by its own scatter.
#[derive(Clone, Copy, Debug)]
pub(super) struct SidebandNoise {
    /// Noise energy of `x`'s mean.
    pub(super) x: f64,
    /// Noise energy of `r`'s mean.
    pub(super) r: f64,
}

impl SidebandNoise {
    /// File `f` against the mean of the others, from each file's mean's noise energy.
    fn between(files: &[f64], f: usize) -> Self {
        let m = (files.len() - 1).max(1) as f64;
        let r = files.iter().enumerate().filter(|(g, _)| *g != f).map(|(_, v)| v).sum::<f64>() / (m * m);
        Self { x: files[f], r }
    }

    /// The growth noise explains: (noise of x + s^2 noise of r) over the reference's own energy.
    pub(super) fn growth(self, c: SidebandChange) -> f64 {
        (self.x + c.scale * c.scale * self.r) / c.own
    }

    /// The growth beyond what the noise explains (at least 0).
    pub(super) fn beyond(self, c: SidebandChange) -> f64 {
        ((c.change / c.own) - self.growth(c)).max(0.0)
    }
}

/// What [`local_reference`] gives: the baseline's mean residual spectrum and how far each file's differs
/// from the others' (local change, sideband growth, pattern change).
#[derive(Default)]
pub(super) struct LocalReference {
    pub(super) residual_mean: OrderSpectrum,
    pub(super) local_healthy: Vec<f64>,
    pub(super) sidebands_healthy: Vec<f64>,
    pub(super) sidebands_beyond_noise: Vec<f64>,
    pub(super) sidebands_noise: Option<f64>,
    pub(super) pattern_healthy: Vec<f64>,
    pub(super) pattern_noise: Vec<f64>,
}

/// The mean of blocks shifted onto one angle origin, and their scatter at the orders the comparisons read.
struct Aligned {
    mean: OrderSpectrum,
    /// At the first-order sidebands ([`tsa_change::sideband_scatter`]).
    sidebands: Option<Scatter>,
    /// At the pattern's orders ([`tsa_change::pattern_scatter`]).
    pattern: Option<Scatter>,
}

/// The mean of `blocks` (order spectra), each shifted onto `reference`'s angle origin first (the blocks in
/// parallel, each with a transform of four times its orders), and their scatter at the orders a gear of
/// `z` teeth is compared on.
fn aligned_blocks(blocks: &[OrderSpectrum], reference: &[(f64, f64)], z: usize) -> Aligned {
    use rayon::prelude::*;
    let shifted: Vec<OrderSpectrum> = blocks
        .par_iter()
        .map_init(Fft::new, |fft, b| tsa_change::advanced(b, tsa_change::align(fft, b, reference).shift))
        .collect();
    Aligned {
        mean: tsa_change::mean(&slices(&shifted)),
        sidebands: tsa_change::sideband_scatter(&shifted, z),
        pattern: tsa_change::pattern_scatter(&shifted, z),
    }
}

/// The local change of gear `g` (its blocks' mean residual against the baseline's mean residual shifted
/// onto the recording's angle origin), with the tooth where it is largest. `None` when the reference has no
/// residual or healthy values, or the recording's residual does not line up with it (correlation under
/// [`MIN_ALIGNMENT`]); `Some(Err(SameData))` when the recording is the baseline's data ([`SameData`]).
/// `shared_step` is z / gcd(z, z_other) on a pair whose teeth share a factor (its
/// orders shared with the other gear are its multiples), else 1. `(one_file, same_load)`: the baseline is
/// a single file; it was stated to be recorded at the recording's load ([`BaselineLoad::Same`]).
pub(super) fn local_change_of(
    fft: &mut Fft,
    g: &GearIndicators,
    r: &GearReference,
    (one_file, same_load): (bool, bool),
    shared_step: usize,
) -> Option<Result<LocalChange, SameData>> {
    // the largest of the baseline files' figures (NaN when there are none)
    let largest = |v: &[f64]| v.iter().copied().fold(f64::NAN, f64::max);
    let healthy = largest(&r.local_healthy);
    if r.residual_mean.len() < 2 || !healthy.is_finite() {
        return None;
    }
    let blocks: Vec<&Block> = g.blocks.iter().collect();
    let own = spectra(&blocks);
    if own.is_empty() {
        return None;
    }
    let a = tsa_change::align(fft, &tsa_change::mean(&slices(&own)), &r.residual_mean);
    if a.correlation < MIN_ALIGNMENT {
        return None;
    }
    // each block shifted onto the baseline's origin (a tracked angle wanders slowly between blocks), then
    // the mean and the baseline's delayed together onto the recording's own origin, so that teeth count
    // from the recording's
    let z = g.mesh_order;
    let Aligned { mean, sidebands: scatter, pattern: pattern_scatter } = aligned_blocks(&own, &r.residual_mean, z);
    let mean = tsa_change::advanced(&mean, -a.shift);
    let reference = tsa_change::advanced(&r.residual_mean, -a.shift);
    let c = tsa_change::concentration(fft, &mean, &reference, z)?;
    let change = tsa_change::sideband_change(&mean, &reference, z);
    if let (Some(c), Some(s)) = (change, scatter) {
        if c.change < SAME_DATA_NOISE * s.of_mean() {
            return Some(Err(SameData));
        }
    }
    let sidebands = change.map_or(f64::NAN, |c| c.change / c.own);
    let sidebands_healthy = largest(&r.sidebands_healthy);
    let sidebands_beyond_noise = largest(&r.sidebands_beyond_noise);
    // the growth the recording's own noise and the baseline's explain: a healthy recording grows by the
    // baseline files' change beyond their noise plus that. The files' growth among themselves holds their
    // own noise instead (a single file's halves twice a whole recording's): the lower of the two limits
    let margin = if one_file { ONE_FILE_NOISE_MARGIN } else { 1.0 };
    let noise = match (change, scatter, r.sidebands_noise) {
        (Some(c), Some(s), Some(rn)) => margin * SidebandNoise { x: s.of_mean(), r: rn }.growth(c),
        _ => f64::NAN,
    };
    // (`sidebands_limit` of NaN is the first path's floor, so the noise path is taken only when both parts
    // are known: a profile written before them, or a recording of one block, keeps the files' limit)
    let files_limit = sidebands_limit(sidebands_healthy);
    let sidebands_limit = if noise.is_finite() && sidebands_beyond_noise.is_finite() {
        sidebands_limit(sidebands_beyond_noise + noise).min(files_limit)
    } else {
        files_limit
    };
    // a single file cannot show what a change of operating point does to the sidebands (unless the
    // recording is stated to be at the file's)
    let sidebands_limit_one_load = sidebands_limit;
    let sidebands_limit =
        if one_file && !same_load { sidebands_limit.max(super::one_file::SIDEBAND_LEAST) } else { sidebands_limit };
    let pattern = tsa_change::pattern_parts(&mean, &reference, z)
        .map_or(f64::NAN, |p| at_baseline_noise(p, pattern_scatter, &r.pattern_noise));
    let pattern_healthy = largest(&r.pattern_healthy);
    let n = tsa_change::points(mean.len().min(reference.len()), z);
    let tooth =
        tsa_change::difference(fft, &mean, &reference, n).and_then(|d| super::super::tooth::impulse_tooth(&d, z));
    Some(Ok(LocalChange {
        gear: g.gear,
        channel: g.channel,
        value: c.ratio,
        healthy,
        limit: (LOCAL_RISE * healthy).max(LOCAL_MIN),
        alignment: a.correlation,
        tooth,
        sidebands,
        sidebands_healthy,
        sidebands_beyond_noise,
        sidebands_noise: noise,
        sidebands_limit,
        sidebands_limit_one_load,
        pattern,
        pattern_healthy,
        own_share: tsa_change::own_share(&mean, &reference, shared_step),
    }))
}

/// The pattern change of a recording read at the baseline's noise: its own noise (its blocks' scatter at
/// the pattern's orders over their count, over the baseline's energy there) taken out and the mean of the
/// baseline files' put in (each file's, or each half's over 2: a half holds twice the noise of a whole
/// file), so that a recording no noisier than the baseline's files reads as before and a noisier one does
/// not read as a change of the gear's teeth. The noise of a gear's average is what does not repeat from
/// revolution to revolution, the other gear's lines among it: a worn 22-tooth pinion of the third
/// generator's 22/67 machine doubled the energy off the mesh in both averages (ER 0.36 -> 0.77), and the
/// wheel's pattern, read on 26 blocks of 3 revolutions, moved 1.84 of its energy against a healthy figure
/// of 0.92, the pinion's 0.43 against 0.33: the wear was put on the wheel. Without a noise allowance
/// (fewer than 2 blocks, a profile written before it) the figure is the plain change.
pub(super) fn at_baseline_noise(
    p: tsa_change::PatternChange,
    own_scatter: Option<Scatter>,
    baseline_noise: &[f64],
) -> f64 {
    let plain = p.change / p.own;
    match own_scatter {
        Some(s) if !baseline_noise.is_empty() => {
            let base = baseline_noise.iter().sum::<f64>() / baseline_noise.len() as f64;
            (plain - s.of_mean() / p.own + base).max(0.0)
        }
        _ => plain,
    }
}

/// A recording whose gear average equals the baseline's to within a small part of its own noise: the same
/// samples (a baseline file judged against itself, or a recording that overlaps one). Its difference from
/// the baseline is rounding and re-alignment, whose shape carries no information (the real rig's healthy
/// 60 % load file against itself put 25.7 times the median pitch's energy at one pitch of a difference
/// 1e-7 of its noise).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SameData;

/// Share of the noise energy the recording's mean holds at the first-order sidebands under which its
/// difference from the baseline there is taken as the same data ([`SameData`]). Two separate recordings
/// differ there by both means' noise, at least the recording's own (a chi-square over 2 x 2 L / z degrees
/// of freedom, L the orders held: at a 1e-6 tail it stays above 0.35 of its mean from 50 degrees of
/// freedom); on the real rig's files a file against itself reads 1e-7 to 1e-3 of it and a file against
/// its neighbouring load 4-20 times it.
const SAME_DATA_NOISE: f64 = 0.25;
