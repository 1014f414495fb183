//! Indicators stage: the condition indicators of each gear's average and of its blocks of whole
//! revolutions, and the checks that a mesh order fits the averages.

use super::super::*;

/// A mesh order `z` that the TSA of `points` samples per revolution of `gear` resolves with room for its
/// sidebands (and is not zero).
///
/// # Errors
/// [`JobError::Input`] naming the file, the order and the speed's source.
pub(in crate::jobs::diagnose) fn check_mesh_order(
    path: &Path,
    z: usize,
    points: usize,
    gear: Shaft,
    source: SpeedSource,
) -> Result<(), Error> {
    if z == 0 {
        return Err(bad(path, format!("mesh order 0 of the {gear}: a gear has at least one tooth")));
    }
    if z.saturating_mul(2).saturating_add(8) <= points / 2 {
        return Ok(());
    }
    Err(bad(
        path,
        format!(
            "mesh order {z} needs more than {points} samples per revolution of the {gear}: the shaft speed ({}) is too high for the sample rate, or the teeth are wrong",
            match source {
                SpeedSource::Estimated => "estimated; give the shaft speed",
                SpeedSource::Given => "given",
                SpeedSource::Tachometer => "from the tachometer",
            }
        ),
    ))
}

/// Points per revolution of a TSA: the revolution's samples rounded up to a power of two (64 ..= 65536).
pub(in crate::jobs::diagnose) fn tsa_points(period: f64) -> usize {
    (period.ceil() as usize).next_power_of_two().clamp(64, 1 << 16)
}

pub(in crate::jobs::diagnose) fn gear_indicators(
    fft: &mut Fft,
    gear: Shaft,
    channel: usize,
    z: usize,
    others: &OtherLines,
    t: &tsa::Tsa,
    shaft_orders: usize,
) -> GearIndicators {
    let (indicators, d) = tsa_indicators(fft, &t.samples, z, others, shaft_orders);
    GearIndicators {
        gear,
        channel,
        mesh_order: z,
        revolutions: t.revolutions,
        indicators,
        residual: d.residual,
        difference: d.difference,
        tsa_amplitudes: d.amplitudes,
        tsa: t.samples.clone(),
        blocks: Vec::new(),
    }
}

/// With a machine, the lines of an averaged shaft besides its gear's mesh: its other gears' mesh orders, and
/// the other stages' mesh harmonics in its orders, both counted as regular.
#[derive(Clone, Debug, Default)]
pub(in crate::jobs::diagnose) struct OtherLines {
    pub mesh: Vec<usize>,
    pub foreign: Vec<f64>,
}

impl OtherLines {
    /// Whether order bin `b` of an average holds one of these lines: a harmonic of another mesh order, or
    /// the bins within one order of a foreign line (what a finite average leaves of a line that is not
    /// synchronous with its shaft).
    pub fn claims(&self, b: usize) -> bool {
        self.mesh.iter().any(|&z| z > 0 && b > 0 && b.is_multiple_of(z))
            || self.foreign.iter().any(|&f| (b as f64 - f).abs() < 1.0)
    }
}

/// The condition indicators of one TSA of a gear with mesh order `z` (its shaft's other lines `others`),
/// and its decomposition.
pub(in crate::jobs::diagnose) fn tsa_indicators(
    fft: &mut Fft,
    x: &[f64],
    z: usize,
    others: &OtherLines,
    shaft_orders: usize,
) -> (Indicators, Decomposition) {
    let d = if others.mesh.is_empty() && others.foreign.is_empty() {
        tsa::decompose(fft, x, z, shaft_orders)
    } else {
        tsa::decompose_many(fft, x, &[&[z][..], &others.mesh].concat(), &others.foreign, shaft_orders)
    };
    let Decomposition { amplitudes, regular_energy, residual, difference } = &d;
    let mesh_amps: Vec<f64> =
        (1..).map(|h| h * z).take_while(|&k| k < amplitudes.len()).map(|k| amplitudes[k]).collect();
    let moments = ind::AverageMoments::of(x);
    // indices checked here: a mesh order beyond the average's resolution (refused by the caller) reads NaN
    let side = match (z.checked_sub(1).and_then(|i| amplitudes.get(i)), amplitudes.get(z + 1)) {
        (Some(a), Some(b)) => a + b,
        _ => f64::NAN,
    };
    let rms = moments.rms;
    let [fm4, m6a, m8a] = ind::normalized_moments_4_6_8(difference);
    let mut m = BTreeMap::new();
    m.insert(Indicator::Rms, rms);
    m.insert(Indicator::Kurtosis, moments.kurtosis);
    m.insert(Indicator::CrestFactor, moments.crest_factor);
    m.insert(Indicator::Fm0, moments.peak_to_peak / mesh_amps.iter().sum::<f64>());
    m.insert(Indicator::Fm4, fm4);
    m.insert(Indicator::M6a, m6a);
    m.insert(Indicator::M8a, m8a);
    m.insert(Indicator::Na4, ind::normalized_moments_4_6_8(residual)[0]);
    m.insert(Indicator::Er, ind::energy_ratio(difference, *regular_energy));
    m.insert(Indicator::Si, side / 2.0);
    m.insert(Indicator::Slf, side / rms);
    m.insert(
        Indicator::Ser,
        if z < amplitudes.len() { ind::sideband_energy_ratio(amplitudes, z, 1) } else { f64::NAN },
    );
    m.insert(Indicator::Sbr, ind::first_sideband_ratio(amplitudes, z, |b| others.claims(b)));
    (m, d)
}

/// A block average of a gear's TSA: its indicators, or the average itself until the gear's mesh order
/// is known.
pub(in crate::jobs::diagnose) enum PendingBlock {
    Done(crate::report::summary::Block),
    Raw(Vec<f64>),
}

/// Blocks from a recording's start whose residual order spectrum is kept for the local-change indicator
/// (256 blocks of 16 revolutions: 4096 revolutions, 16 MB at most per gear and channel).
const SPECTRUM_BLOCKS: usize = 256;

/// Whether block `i` keeps its residual's order spectrum: the first [`SPECTRUM_BLOCKS`] when a baseline's
/// change will be measured.
pub(in crate::jobs::diagnose) fn keeps_spectrum(o: &Options, i: usize) -> bool {
    o.residual_spectra && i < SPECTRUM_BLOCKS
}
/// Highest order of a block's residual spectrum kept (a crack's change lives up to the housing's
/// resonances, far above the mesh harmonics: 4096 orders of a 12 Hz shaft reach 49 kHz).
const SPECTRUM_ORDERS: usize = 4096;

/// Indicators of one block average of a gear (consecutive blocks of whole revolutions; the statistical
/// baseline's samples; a recording under test is scored by the median of its own blocks, so both sides
/// average the same number of revolutions); with `spectrum` the block keeps its residual's order spectrum.
pub(in crate::jobs::diagnose) fn block_indicators(
    fft: &mut Fft,
    block: &[f64],
    z: usize,
    others: &OtherLines,
    shaft_orders: usize,
    spectrum: bool,
) -> crate::report::summary::Block {
    let (mut indicators, d) = tsa_indicators(fft, block, z, others, shaft_orders);
    let n = d.residual.len() as f64;
    let mean = d.residual.iter().sum::<f64>() / n;
    indicators.insert(Indicator::ResidualM2, d.residual.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n);
    indicators.insert(Indicator::ResidualM4, d.residual.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n);
    let residual_spectrum = if spectrum {
        crate::signal::tsa_change::order_spectrum(fft, &d.residual, SPECTRUM_ORDERS)
    } else {
        Vec::new()
    };
    crate::report::summary::Block { indicators, amplitudes: d.amplitudes, residual_spectrum }
}
