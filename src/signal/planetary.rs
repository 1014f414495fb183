//! Vibration separation of a planetary stage (McFadden 1991; windows as McFadden 1994): the time-domain
//! average of each planet gear, assembled from short windows cut where that planet passes the sensor.
//!
//! ```text
//! input: the signal resampled uniformly in carrier angle, L_c samples per carrier revolution, L_c a multiple
//!        of the ring teeth z_r; tooth period P = L_c / z_r samples (the same for ring and planet meshes)
//! planet i passes the sensor at carrier angle psi_i + 360 j degrees (psi_1 = 0: planet 1 is at the sensor
//!        at the carrier's tachometer pulse), pass centre c_ij = round((psi_i / 360 + j) L_c)
//! planet tooth meshing there: t_ij = (j z_r) mod z_p (the planet turns z_r teeth per carrier revolution
//!        relative to the carrier; tooth 0 is the one meshing at planet i's first pass)
//! window of W = K P samples centred on c_ij, weights w (rectangular or Hann), overlap-added circularly into
//!        a buffer of z_p P samples at t_ij P - W / 2, the weights into a second buffer
//! average_i = signal buffer / weight buffer; a zero weight means incomplete coverage (no average)
//! ```
//! A one-tooth window (K = 1) visits only z_p / gcd(z_r, z_p) planet teeth: K must be at least gcd(z_r, z_p)
//! for every tooth to be covered. Keep W well below the planet spacing (about z_r / N_p teeth): the other
//! planets' vibration leaks in otherwise. Pass centres are rounded to the nearest sample (an error of at
//! most half a sample; none when psi_i L_c / 360 is whole).

use super::SignalError;

/// The window applied to each planet passage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeparationWindow {
    /// Rectangular (McFadden 1991).
    Rectangular,
    /// Hann (periodic, W samples); a taper lowers the error of the assembled average (McFadden 1994).
    Hann,
}

/// Options of [`planet_averages`].
#[derive(Clone, Debug)]
pub struct PlanetSeparation {
    /// Ring teeth z_r.
    pub ring_teeth: usize,
    /// Planet teeth z_p.
    pub planet_teeth: usize,
    /// Carrier angle at which each planet passes the sensor after planet 1, degrees (first 0).
    pub planet_angles_deg: Vec<f64>,
    /// Samples per carrier revolution L_c (a multiple of `ring_teeth`).
    pub samples_per_rev: usize,
    /// Window length K in tooth periods.
    pub window_teeth: usize,
    /// Window shape.
    pub window: SeparationWindow,
}

/// One planet's separated average.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanetAverage {
    /// Average over one planet revolution relative to the carrier: z_p P samples, tooth t at t P.. (t + 1) P,
    /// in the signal's unit; `None` when some position was never covered by a window.
    pub samples: Option<Vec<f64>>,
    /// Passes averaged.
    pub passes: usize,
}

fn window(kind: SeparationWindow, w: usize) -> Vec<f64> {
    match kind {
        SeparationWindow::Rectangular => vec![1.0; w],
        SeparationWindow::Hann => {
            (0..w).map(|n| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * (n as f64 + 0.5) / w as f64).cos()).collect()
        }
    }
}

/// The separated average of every planet (in `planet_angles_deg` order) from `signal`, resampled in carrier
/// angle as the module doc says; only passes whose whole window lies inside the signal are used.
///
/// # Errors
/// [`SignalError::Invalid`] for teeth below 3, `samples_per_rev` not a multiple of the ring teeth, an
/// empty or zero window, a window longer than the planet spacing allows, angles not in [0, 360);
/// [`SignalError::TooShort`] for a signal shorter than one carrier revolution.
pub fn planet_averages(signal: &[f64], o: &PlanetSeparation) -> Result<Vec<PlanetAverage>, SignalError> {
    let (zr, zp, lc) = (o.ring_teeth, o.planet_teeth, o.samples_per_rev);
    if zr < 3 || zp < 3 {
        return Err(SignalError::Invalid(format!("ring and planet need at least 3 teeth, got {zr} and {zp}")));
    }
    if lc == 0 || lc % zr != 0 {
        return Err(SignalError::Invalid(format!(
            "{lc} samples per carrier revolution is not a multiple of the {zr} ring teeth"
        )));
    }
    let np = o.planet_angles_deg.len();
    if np == 0 || o.planet_angles_deg.iter().any(|a| !(a.is_finite() && (0.0..360.0).contains(a))) {
        return Err(SignalError::Invalid("planet angles must be given, each in [0, 360) degrees".into()));
    }
    let p = lc / zr;
    let w = o.window_teeth * p;
    // the nearest other planet must stay outside the window
    let spacing = (0..np)
        .flat_map(|i| (0..np).filter(move |&j| j != i).map(move |j| (i, j)))
        .map(|(i, j)| {
            let d = (o.planet_angles_deg[i] - o.planet_angles_deg[j]).rem_euclid(360.0);
            d.min(360.0 - d)
        })
        .fold(360.0, f64::min);
    if w == 0 || (w as f64) > spacing / 360.0 * lc as f64 {
        return Err(SignalError::Invalid(format!(
            "a window of {} teeth ({w} samples) must be non-empty and shorter than the closest planet spacing ({:.1} teeth)",
            o.window_teeth,
            spacing / 360.0 * zr as f64
        )));
    }
    if signal.len() < lc {
        return Err(SignalError::TooShort { what: "planet separation".into(), needed: lc, got: signal.len() });
    }
    let taper = window(o.window, w);
    let len = zp * p;
    let revs = signal.len() / lc + 1;
    let mut out = Vec::with_capacity(np);
    for &psi in &o.planet_angles_deg {
        let (mut sum, mut weight) = (vec![0.0; len], vec![0.0; len]);
        let mut passes = 0;
        for j in 0..revs {
            let centre = ((psi / 360.0 + j as f64) * lc as f64).round() as usize;
            let Some(start) = centre.checked_sub(w / 2) else { continue };
            if start + w > signal.len() {
                break;
            }
            let tooth = (j * zr) % zp;
            // buffer position of the window's first sample: t P - W / 2, circular
            let at = (tooth * p + len - (w / 2) % len) % len;
            for (m, (&x, &wt)) in signal[start..start + w].iter().zip(&taper).enumerate() {
                let k = (at + m) % len;
                sum[k] += wt * x;
                weight[k] += wt;
            }
            passes += 1;
        }
        let samples = weight.iter().all(|&v| v > 0.0).then(|| sum.iter().zip(&weight).map(|(s, v)| s / v).collect());
        out.push(PlanetAverage { samples, passes });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A planet's vibration over its teeth u (continuous tooth position).
    type Signature = Box<dyn Fn(f64) -> f64>;

    /// Three planets (z_r 83, z_p 31, at 0, 34 and 70 ring pitches of 104 = 117.7 and 242.3 degrees), each
    /// with its own signature g_i(u) over its teeth u (a mesh tone plus, on planet 2, a local fault on tooth
    /// 5), seen through a passage envelope a(theta - psi_i) that is 1 within 4 teeth of the sensor and
    /// falls to 0 (raised cosine) 10 teeth away: planet-pass amplitude modulation. With a window of 3
    /// teeth the envelope is flat under each window and the other planets are silent, so the separated
    /// average of planet i must equal g_i exactly (the closed form of the construction).
    fn build(window: SeparationWindow, revs: usize) -> (Vec<f64>, PlanetSeparation, Vec<Signature>) {
        let (zr, zp) = (83usize, 31usize);
        // L_c a multiple of 83 and of 104 / gcd: every pass centre on a sample
        let lc = 83 * 52;
        let p = (lc / zr) as f64;
        let angles = vec![0.0, 34.0 * 360.0 / 104.0, 70.0 * 360.0 / 104.0];
        let sig = |fault: bool| -> Signature {
            Box::new(move |u: f64| {
                let mut v = (2.0 * PI * u).cos() + 0.3 * (4.0 * PI * u + 0.4).cos();
                if fault {
                    let d = (u - 5.0 + zp as f64 / 2.0).rem_euclid(zp as f64) - zp as f64 / 2.0;
                    v += 2.0 * (-d * d / (2.0 * 0.15 * 0.15)).exp();
                }
                v
            })
        };
        let g: Vec<Signature> = vec![sig(false), sig(true), sig(false)];
        let envelope = |teeth_from_sensor: f64| {
            let d = teeth_from_sensor.abs();
            if d <= 4.0 {
                1.0
            } else if d >= 10.0 {
                0.0
            } else {
                0.5 + 0.5 * (PI * (d - 4.0) / 6.0).cos()
            }
        };
        let n = revs * lc;
        let signal: Vec<f64> = (0..n)
            .map(|s| {
                angles
                    .iter()
                    .zip(&g)
                    .map(|(psi, gi)| {
                        let c0 = psi / 360.0 * lc as f64;
                        // teeth from the sensor, wrapped to the nearest pass
                        let rel = (s as f64 - c0) / p;
                        let from = (rel + zr as f64 / 2.0).rem_euclid(zr as f64) - zr as f64 / 2.0;
                        // planet tooth meshing: the planet advances one tooth per ring tooth period
                        let u = rel.rem_euclid(zp as f64);
                        envelope(from) * gi(u)
                    })
                    .sum()
            })
            .collect();
        let opts = PlanetSeparation {
            ring_teeth: zr,
            planet_teeth: zp,
            planet_angles_deg: angles,
            samples_per_rev: lc,
            window_teeth: 3,
            window,
        };
        (signal, opts, g)
    }

    #[test]
    fn planet_averages_works() {
        for window in [SeparationWindow::Rectangular, SeparationWindow::Hann] {
            // 62 revolutions: every planet tooth under the 3-tooth windows at least twice
            let (signal, opts, g) = build(window, 62);
            let avg = planet_averages(&signal, &opts).unwrap();
            let p = opts.samples_per_rev / opts.ring_teeth;
            for (i, a) in avg.iter().enumerate() {
                let s = a.samples.as_ref().expect("every tooth covered");
                let worst =
                    s.iter().enumerate().map(|(k, v)| (v - g[i](k as f64 / p as f64)).abs()).fold(0.0, f64::max);
                // the construction makes the average exactly g_i: rounding only, that of the tooth positions
                // u ~ 5e3 teeth in the construction (5e3 x 2 pi x 2e-16 ~ 1e-11 in a phase)
                assert!(worst < 1e-10, "{window:?} planet {}: {worst:e}", i + 1);
            }
            // the faulty planet is the one whose average holds the bump, on tooth 5
            let bump: Vec<(usize, f64)> = avg
                .iter()
                .map(|a| {
                    let s = a.samples.as_ref().unwrap();
                    let (k, v) =
                        s.iter().enumerate().fold((0, f64::MIN), |b, (k, v)| if *v > b.1 { (k, *v) } else { b });
                    (k / p, v)
                })
                .collect();
            assert_eq!(bump[1].0, 5);
            assert!(bump[1].1 > 2.0 && bump[0].1 < 1.31 && bump[2].1 < 1.31, "{bump:?}");
        }
    }

    #[test]
    fn planet_averages_rejects_bad_requests() {
        let (signal, mut opts, _) = build(SeparationWindow::Hann, 3);
        // 3 revolutions are too few for every tooth: no average rather than a partial one
        assert!(planet_averages(&signal, &opts).unwrap().iter().all(|a| a.samples.is_none()));
        opts.window_teeth = 40;
        assert!(matches!(planet_averages(&signal, &opts), Err(SignalError::Invalid(_))));
        opts.window_teeth = 3;
        opts.samples_per_rev += 1;
        assert!(matches!(planet_averages(&signal, &opts), Err(SignalError::Invalid(_))));
    }
}
