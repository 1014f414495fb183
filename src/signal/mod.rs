//! Signals and their analysis: spectra, windows, TSA, indicators, sidebands, comparison.
//! Knows nothing of ODEs or gears' equations of motion: it sees sample arrays, rates and orders.

pub mod angle;
pub mod envelope;
pub mod indicators;
pub mod interpolate;
pub mod mesh_comb;
pub mod order_map;
pub mod planetary;
pub mod spectrum;
pub mod speed;
pub mod tsa;
pub mod tsa_change;
pub mod velocity;

#[cfg(test)]
pub(crate) mod test_noise {
    //! Seeded noise for the signal layer's unit tests.

    /// Uniform noise on [-0.5, 0.5) from a seeded linear congruential generator (Knuth's MMIX constants).
    pub(crate) fn uniform_noise(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        }
    }
}

/// Errors of the signal layer.
#[derive(Debug, thiserror::Error)]
pub enum SignalError {
    /// Input too short for the requested analysis.
    #[error("{what}: needs at least {needed} samples, got {got}")]
    TooShort {
        /// What needed them.
        what: String,
        /// Samples needed.
        needed: usize,
        /// Samples available.
        got: usize,
    },
    /// A parameter is out of range.
    #[error("{0}")]
    Invalid(String),
}

/// A sample type the analysis accepts (f32 storage halves the memory of long recordings).
pub trait Sample: Copy + Send + Sync {
    /// As f64.
    fn f(self) -> f64;
    /// `sum_k x[k] taps[k]` over 16 samples, in eight independent lanes (so the compiler vectorises it).
    fn dot16(x: &[Self], taps: &[f32; 16]) -> f64;
    /// The samples as f32, when they are (for the interpolation's explicit vector kernel).
    fn as_f32(x: &[Self]) -> Option<&[f32]>;
}

impl Sample for f32 {
    fn f(self) -> f64 {
        f64::from(self)
    }
    #[inline(always)]
    fn dot16(x: &[f32], taps: &[f32; 16]) -> f64 {
        let x: &[f32; 16] = x.try_into().expect("16 samples");
        // a tree of lane-wise sums: 8 lanes, then 4, 2, 1 (one 256-bit vector where AVX is enabled)
        let a: [f32; 8] = std::array::from_fn(|k| x[k] * taps[k] + x[k + 8] * taps[k + 8]);
        let b: [f32; 4] = std::array::from_fn(|k| a[k] + a[k + 4]);
        f64::from((b[0] + b[2]) + (b[1] + b[3]))
    }
    fn as_f32(x: &[f32]) -> Option<&[f32]> {
        Some(x)
    }
}

impl Sample for f64 {
    fn f(self) -> f64 {
        self
    }
    #[inline(always)]
    fn dot16(x: &[f64], taps: &[f32; 16]) -> f64 {
        let x: &[f64; 16] = x.try_into().expect("16 samples");
        let a: [f64; 8] = std::array::from_fn(|k| x[k] * f64::from(taps[k]) + x[k + 8] * f64::from(taps[k + 8]));
        let b: [f64; 4] = std::array::from_fn(|k| a[k] + a[k + 4]);
        (b[0] + b[2]) + (b[1] + b[3])
    }
    fn as_f32(_: &[f64]) -> Option<&[f32]> {
        None
    }
}

/// A uniformly sampled real signal.
#[derive(Clone, Debug, PartialEq)]
pub struct Signal {
    /// Samples in the signal's physical unit.
    pub samples: Vec<f64>,
    /// Sample rate in Hz.
    pub sample_rate_hz: f64,
}

/// A one-sided spectrum with its frequency axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// Bin frequencies in Hz.
    pub freqs_hz: Vec<f64>,
    /// Values (amplitude in the signal unit, or PSD in unit^2/Hz).
    pub values: Vec<f64>,
}

impl Spectrum {
    /// Largest value within `width_hz` of `f_hz` and the frequency where it is (`None` outside the axis).
    pub fn peak_near(&self, f_hz: f64, width_hz: f64) -> Option<(f64, f64)> {
        let df = self.freqs_hz.get(1).map_or(1.0, |f1| f1 - self.freqs_hz[0]);
        let lo = self.freqs_hz.partition_point(|&f| f < f_hz - width_hz.max(df));
        let hi = self.freqs_hz.partition_point(|&f| f <= f_hz + width_hz.max(df));
        (lo..hi).map(|i| (self.freqs_hz[i], self.values[i])).max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The sinusoid within `width_hz` of `f_hz` of a Hann-windowed amplitude spectrum, corrected for
    /// scalloping: from the peak bin k and its larger neighbour, alpha = A(k +- 1) / A(k) gives the offset
    /// delta = (2 alpha - 1) / (alpha + 1) bins (exact for the Hann main lobe), and the amplitude is
    /// A(k) / W(delta) with W(d) = sinc(d) / (1 - d^2), the window's normalised response (a line midway
    /// between bins otherwise reads 0.85 of its amplitude). Returns (frequency in Hz, amplitude).
    pub fn hann_line_near(&self, f_hz: f64, width_hz: f64) -> Option<(f64, f64)> {
        let df = self.freqs_hz.get(1).map_or(1.0, |f1| f1 - self.freqs_hz[0]);
        let lo = self.freqs_hz.partition_point(|&f| f < f_hz - width_hz.max(df));
        let hi = self.freqs_hz.partition_point(|&f| f <= f_hz + width_hz.max(df));
        let k = (lo..hi).max_by(|&a, &b| self.values[a].total_cmp(&self.values[b]))?;
        let a = self.values[k];
        if k == 0 || k + 1 >= self.values.len() || a <= 0.0 {
            return Some((self.freqs_hz[k], a));
        }
        let (left, right) = (self.values[k - 1], self.values[k + 1]);
        let (alpha, sign) = if right >= left { (right / a, 1.0) } else { (left / a, -1.0) };
        let delta = ((2.0 * alpha - 1.0) / (alpha + 1.0)).clamp(0.0, 0.5);
        let response = if delta == 0.0 {
            1.0
        } else {
            let x = std::f64::consts::PI * delta;
            x.sin() / x / (1.0 - delta * delta)
        };
        Some((self.freqs_hz[k] + sign * delta * df, a / response))
    }
}
