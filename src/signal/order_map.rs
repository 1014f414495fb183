//! The rpm-order map (Campbell / waterfall view) of a recording whose speed changes: short order spectra of
//! consecutive groups of revolutions, each at its own mean speed. A line fixed to the shaft (a mesh order)
//! stays in one column; a resonance, fixed in frequency, moves across orders as 1 / speed.

use super::spectrum::{Fft, hann};
use super::tsa::{AngleMap, Interpolator};
use super::{Sample, SignalError};

/// Order amplitudes against speed.
#[derive(Clone, Debug)]
pub struct OrderMap {
    /// Order of each column (bin k of a segment of R revolutions is order k / R).
    pub orders: Vec<f64>,
    /// Mean speed of each row in revolutions per sample (times the sample rate: rev/s).
    pub speeds: Vec<f64>,
    /// Amplitude (units of `x`, Hann-corrected) per row and column.
    pub amplitudes: Vec<Vec<f64>>,
}

/// The order map of `x` on the angle `map`: segments of `segment_revs` revolutions advancing by
/// `step_revs`, each resampled at `points` equal angles per revolution (windowed-sinc interpolation),
/// mean removed, Hann window, amplitude spectrum by order up to `max_order`. Rows come sorted by speed
/// (a coast-down reads like a run-up).
///
/// # Errors
/// Fewer revolutions than one segment, zero sizes, or `points` too few for `max_order`.
pub fn order_map<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    map: &AngleMap,
    points: usize,
    segment_revs: usize,
    step_revs: usize,
    max_order: f64,
) -> Result<OrderMap, SignalError> {
    if segment_revs == 0 || step_revs == 0 || points < 4 {
        return Err(SignalError::Invalid("order map: segment, step and points must be positive".into()));
    }
    if max_order <= 0.0 || max_order > points as f64 / 2.0 {
        return Err(SignalError::Invalid(format!(
            "order map: order {max_order} needs more than {points} points per revolution"
        )));
    }
    let revs = map.revolutions();
    if revs < segment_revs {
        return Err(SignalError::TooShort { what: "order map (revolutions)".into(), needed: segment_revs, got: revs });
    }
    let interp = Interpolator::shared();
    let n = segment_revs * points;
    let window = hann(n);
    let gain: f64 = window.iter().sum();
    let columns = ((max_order * segment_revs as f64).floor() as usize).min(n / 2);
    let mut rows = Vec::new();
    let (mut y, mut at, mut spec) = (vec![0.0; n], vec![0.0; n], Vec::new());
    for first in (0..=revs - segment_revs).step_by(step_revs) {
        map.fill_positions(first as f64, 1.0 / points as f64, &mut at);
        interp.fill(x, &at, &mut y);
        let mean = y.iter().sum::<f64>() / n as f64;
        y.iter_mut().zip(&window).for_each(|(v, w)| *v = (*v - mean) * w);
        fft.forward(&mut y, &mut spec);
        let amps: Vec<f64> = spec[..=columns].iter().map(|c| 2.0 * super::spectrum::magnitude(*c) / gain).collect();
        let span = map.sample_at((first + segment_revs) as f64) - map.sample_at(first as f64);
        rows.push((segment_revs as f64 / span, amps));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(OrderMap {
        orders: (0..=columns).map(|k| k as f64 / segment_revs as f64).collect(),
        speeds: rows.iter().map(|r| r.0).collect(),
        amplitudes: rows.into_iter().map(|r| r.1).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn a_shaft_order_stays_in_its_column_and_a_resonance_moves_as_one_over_speed() {
        // a run-up from 20 to 30 rev/s over 4 s at 8192 Hz: angle theta(t) = 20 t + 1.25 t^2 revolutions
        // (exact), order 7 of amplitude 1.0 and a fixed 400 Hz line of amplitude 0.5
        let fs = 8192.0;
        let n = (4.0 * fs) as usize;
        let theta = |t: f64| 20.0 * t + 1.25 * t * t;
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 / fs;
                (TAU * 7.0 * theta(t)).cos() + 0.5 * (TAU * 400.0 * t).cos()
            })
            .collect();
        // revolution starts solved exactly from theta(t) = k
        let starts: Vec<f64> = (0..)
            .map(|k| (-20.0 + (400.0 + 5.0 * k as f64).sqrt()) / 2.5 * fs)
            .take_while(|s| *s < (n - 1) as f64)
            .collect();
        let map = AngleMap::from_pulses(&starts, 1);
        let m = order_map(&mut Fft::new(), &x, &map, 64, 8, 4, 30.0).unwrap();
        assert!(m.speeds.len() >= 20);
        assert!(m.speeds.windows(2).all(|w| w[0] <= w[1]));
        for (speed, row) in m.speeds.iter().zip(&m.amplitudes) {
            let hz = speed * fs;
            assert!((19.9..30.1).contains(&hz), "{hz}");
            // order 7 sits on bin 56 of an 8-revolution segment: no scalloping, and a 1.3 % speed change
            // within the segment spreads it only a little in angle (it is locked to the angle): 2 %
            assert!((row[56] - 1.0).abs() < 0.02, "{hz} Hz: {}", row[56]);
            // the 400 Hz line: at order 400 / speed (its own spread over the segment's speed change:
            // the peak within 1.5 % of that order)
            let want = 400.0 / hz;
            let (k, _) = row
                .iter()
                .enumerate()
                .skip(8)
                .filter(|(k, _)| (*k as i64 - 56).abs() > 3)
                .fold((0, 0.0), |best, (k, a)| if *a > best.1 { (k, *a) } else { best });
            assert!((m.orders[k] / want - 1.0).abs() < 0.015, "{hz} Hz: peak at order {} for {want}", m.orders[k]);
        }
    }

    #[test]
    fn too_few_revolutions_or_points_are_refused() {
        let map = AngleMap::constant(100.0, 0.0, 1000);
        let x = vec![0.0f64; 1000];
        assert!(order_map(&mut Fft::new(), &x, &map, 64, 16, 4, 10.0).is_err());
        assert!(order_map(&mut Fft::new(), &x, &map, 16, 4, 2, 10.0).is_err());
    }
}
