//! The measured side of `identify`: the recording's shaft angle (tachometer, else the mesh phase), and
//! the complex order coefficients of the vibration averaged over whole model periods, each with its
//! standard error from the scatter between periods.
//!
//! ```text
//! period P = the pinion revolutions the fit needs (1, or the hunting period z2 / gcd(z1, z2) with wheel orders)
//! A_r(m) = (2 / N) sum_n x_r(n) exp(-i 2 pi m n / N)     period r resampled at N = L P angles, m = period order
//! A(m) = mean_r A_r(m),  var A(m) = sum_r |A_r(m) - A(m)|^2 / (R (R - 1))
//! ```
//! so that x(theta) = sum_m Re(A(m) exp(i m 2 pi theta / P)), theta in pinion revolutions.

use crate::report::summary::PhaseOrigin;
use crate::signal::angle::{self, SpeedProfile};
use crate::signal::spectrum::Fft;
use crate::signal::speed::tacho_pulses;
use crate::signal::tsa::{AngleMap, tsa_of_revolutions};
use crate::system::gcd;
use nalgebra::Complex;

/// The tracked angle of a recording.
pub struct Angle {
    /// Pinion revolution starts.
    pub map: AngleMap,
    /// Origin of the pinion angle.
    pub origin: PhaseOrigin,
    /// Index of the first pinion revolution where the wheel is at its angle 0 too (from a wheel
    /// tachometer), when known.
    pub wheel_start: Option<usize>,
    /// Speed profile of the pinion.
    pub speed: SpeedProfile,
}

/// Angle from a pinion tachometer channel (and a wheel one, which fixes the start of a hunting period).
///
/// # Errors
/// Pulse trains that do not give two revolutions, or miss pulses.
pub fn angle_from_tacho(pinion: &[f32], wheel: Option<&[f32]>, teeth: (usize, usize)) -> Result<Angle, String> {
    let pulses = tacho_pulses(pinion).map_err(|e| e.to_string())?;
    let map = angle::from_pulses(&pulses, 1).map_err(|e| e.to_string())?;
    let wheel_start = wheel.and_then(|w| tacho_pulses(w).ok()).and_then(|wp| first_common_start(&pulses, &wp, teeth));
    let speed = SpeedProfile::of(&map);
    Ok(Angle { map, origin: PhaseOrigin::Tachometer, wheel_start, speed })
}

/// The first pinion pulse within a quarter tooth pitch of a wheel pulse (both gears at angle 0), among
/// the first z2 / gcd pinion revolutions.
fn first_common_start(pinion: &[f64], wheel: &[f64], teeth: (usize, usize)) -> Option<usize> {
    let hunting = teeth.1 / gcd(teeth.0, teeth.1);
    let pitch = (pinion.get(1)? - pinion[0]) / teeth.0 as f64;
    pinion.iter().take(hunting + 1).position(|&p| {
        let i = wheel.partition_point(|&w| w < p);
        let near = |j: usize| wheel.get(j).is_some_and(|w| (w - p).abs() < 0.25 * pitch);
        near(i) || (i > 0 && near(i - 1))
    })
}

/// Angle from the phase of the first mesh harmonic (no tachometer): `period` is the nominal revolution in
/// samples (from the scene's speed), `z1` the pinion teeth.
///
/// # Errors
/// The mesh line cannot be followed.
pub fn angle_from_mesh(x: &[f32], period: f64, z1: usize) -> Result<Angle, String> {
    let tracked = angle::track_mesh(x, period, z1 as f64).map_err(|e| e.to_string())?;
    let speed = SpeedProfile::of(&tracked.map);
    Ok(Angle { map: tracked.map, origin: PhaseOrigin::Arbitrary, wheel_start: None, speed })
}

/// Order coefficients of one recording channel averaged over whole periods.
#[derive(Clone, Debug)]
pub struct Coefficients {
    /// Pinion revolutions per period P.
    pub period_revs: usize,
    /// A(m) for m = 0..=max, one-sided complex amplitudes in the recording's unit.
    pub mean: Vec<Complex<f64>>,
    /// Standard error of each A(m) (root of E|A - A_true|^2), same unit.
    pub std_error: Vec<f64>,
    /// Periods averaged R.
    pub periods: usize,
}

/// The coefficients up to period order `max_m` from `periods` periods of `period_revs` pinion revolutions
/// from the first start of `map`, each resampled at `points_per_rev` angles per revolution (a
/// power of two above the samples per revolution, so no line is lost).
pub fn coefficients(
    x: &[f32],
    map: &AngleMap,
    period_revs: usize,
    periods: usize,
    points_per_rev: usize,
    max_m: usize,
) -> Coefficients {
    let n = points_per_rev * period_revs;
    let ratio = 1.0 / period_revs as f64;
    let per_period: Vec<Vec<Complex<f64>>> = {
        use rayon::prelude::*;
        (0..periods)
            .into_par_iter()
            .map_init(Fft::new, |fft, r| {
                // period r is revolution r of the shaft that turns 1/P times per pinion revolution
                let mut buf = tsa_of_revolutions(x, map, ratio, n, r..r + 1);
                let mut spec = Vec::new();
                fft.forward(&mut buf, &mut spec);
                let scale = 2.0 / n as f64;
                (0..=max_m.min(n / 2))
                    .map(|m| {
                        let (re, im) = spec[m];
                        let k = if m == 0 { 0.5 * scale } else { scale };
                        Complex::new(re * k, im * k)
                    })
                    .collect()
            })
            .collect()
    };
    let lines = max_m.min(n / 2) + 1;
    let r = periods.max(1) as f64;
    let mean: Vec<Complex<f64>> =
        (0..lines).map(|m| per_period.iter().map(|p| p[m]).sum::<Complex<f64>>() / r).collect();
    let std_error = (0..lines)
        .map(|m| {
            let ss: f64 = per_period.iter().map(|p| (p[m] - mean[m]).norm_sqr()).sum();
            (ss / (r * (r - 1.0)).max(1.0)).sqrt()
        })
        .collect();
    Coefficients { period_revs, mean, std_error, periods }
}
