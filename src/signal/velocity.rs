//! Overall vibration velocity: the RMS velocity over a frequency band (10-1000 Hz, as ISO 10816-3 and
//! ISO 20816-3 ask of machine housings) from an amplitude spectrum, and the zone boundaries of the machine
//! classes of those standards.
//!
//! ```text
//! mean square over the band = sum_k A_k^2 / 2 / ENBW         (A_k amplitude-corrected Hann spectrum)
//! velocity line             = A_k / (2 pi f_k)               (when the spectrum is of acceleration)
//! ENBW (periodic Hann)      = N sum w^2 / (sum w)^2 = 1.5 bins
//! ```
//! Each sinusoid is spread by the window over about 1.5 bins, so the sum of the bins' squared amplitudes
//! counts its power 1.5 times; dividing by the ENBW gives Parseval's mean square back.

use super::Spectrum;

/// What an amplitude spectrum measures, with the factor from its unit to SI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Measured {
    /// Velocity; the factor turns the unit into m/s.
    Velocity(f64),
    /// Acceleration; the factor turns the unit into m/s^2.
    Acceleration(f64),
}

/// The quantity a unit names (`m/s`, `mm/s`, `in/s`, `m/s^2`, `mm/s^2`, `g`), `None` for any other
/// (displacement, volts, no unit): the velocity cannot be had from it.
pub fn measured_from_unit(unit: &str) -> Option<Measured> {
    let u: String = unit.trim().chars().filter(|c| !c.is_whitespace()).collect();
    match u.as_str() {
        "m/s" => Some(Measured::Velocity(1.0)),
        "mm/s" => Some(Measured::Velocity(1e-3)),
        "in/s" | "ips" => Some(Measured::Velocity(0.0254)),
        "m/s^2" | "m/s2" | "m/s²" | "m/s/s" => Some(Measured::Acceleration(1.0)),
        "mm/s^2" | "mm/s2" | "mm/s²" => Some(Measured::Acceleration(1e-3)),
        "g" => Some(Measured::Acceleration(9.80665)),
        _ => None,
    }
}

/// RMS velocity in mm/s over `band_hz` (both ends included) of the one-sided amplitude spectrum `s` of
/// averaged Hann segments (`signal::spectrum::amplitude_from_power`). `None` when the band reaches above
/// the spectrum's last bin (the sample rate is too low for it) or the spectrum is empty.
pub fn velocity_rms_mm_s(s: &Spectrum, measured: Measured, band_hz: (f64, f64)) -> Option<f64> {
    let last = *s.freqs_hz.last()?;
    if band_hz.1 > last || band_hz.0 <= 0.0 || band_hz.1 <= band_hz.0 {
        return None;
    }
    const HANN_ENBW_BINS: f64 = 1.5;
    let ms: f64 = s
        .freqs_hz
        .iter()
        .zip(&s.values)
        .filter(|(f, _)| **f >= band_hz.0 && **f <= band_hz.1)
        .map(|(f, a)| {
            let v = match measured {
                Measured::Velocity(k) => a * k,
                Measured::Acceleration(k) => a * k / (2.0 * std::f64::consts::PI * f),
            };
            v * v / 2.0
        })
        .sum();
    Some(1e3 * (ms / HANN_ENBW_BINS).sqrt())
}

/// The machine classes of ISO 10816-3 (group 1: 300 kW to 50 MW; group 2: 15 to 300 kW) on rigid or
/// flexible supports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MachineClass {
    /// Group 1, rigid support.
    Group1Rigid,
    /// Group 1, flexible support.
    Group1Flexible,
    /// Group 2, rigid support.
    Group2Rigid,
    /// Group 2, flexible support.
    Group2Flexible,
}

/// Evaluation zones: A newly commissioned, B unrestricted long-term operation, C limited time, D damaging.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Zone {
    /// Newly commissioned machines.
    A,
    /// Acceptable for unrestricted long-term operation.
    B,
    /// Acceptable for a limited time only.
    C,
    /// Severe enough to cause damage.
    D,
}

impl Zone {
    /// The zone's letter and meaning.
    pub fn words(self) -> &'static str {
        match self {
            Self::A => "zone A (newly commissioned)",
            Self::B => "zone B (unrestricted long-term operation)",
            Self::C => "zone C (limited time only)",
            Self::D => "zone D (damaging)",
        }
    }
}

impl MachineClass {
    /// All classes, as named on the command line.
    pub const ALL: [(&'static str, MachineClass); 4] = [
        ("group1-rigid", Self::Group1Rigid),
        ("group1-flexible", Self::Group1Flexible),
        ("group2-rigid", Self::Group2Rigid),
        ("group2-flexible", Self::Group2Flexible),
    ];

    /// The class of a name of [`Self::ALL`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(n, _)| *n == name).map(|(_, c)| *c)
    }

    /// The name of the class.
    pub fn name(self) -> &'static str {
        Self::ALL.iter().find(|(_, c)| *c == self).map_or("", |(n, _)| n)
    }

    /// Zone boundaries A/B, B/C, C/D in mm/s RMS over 10-1000 Hz. Source: ISO 10816-3:2009 as quoted by
    /// public configurations (not checked against the standard's text; whether ISO 20816-3:2022 kept
    /// them is not confirmed): treat them as the user's configuration.
    pub fn boundaries_mm_s(self) -> [f64; 3] {
        match self {
            Self::Group1Rigid => [2.3, 4.5, 7.1],
            Self::Group1Flexible => [3.5, 7.1, 11.0],
            Self::Group2Rigid => [1.4, 2.8, 4.5],
            Self::Group2Flexible => [2.3, 4.5, 7.1],
        }
    }

    /// The zone of an RMS velocity `v_mm_s` (a value on a boundary belongs to the worse zone).
    pub fn zone(self, v_mm_s: f64) -> Zone {
        let [ab, bc, cd] = self.boundaries_mm_s();
        if v_mm_s < ab {
            Zone::A
        } else if v_mm_s < bc {
            Zone::B
        } else if v_mm_s < cd {
            Zone::C
        } else {
            Zone::D
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::spectrum::{amplitude_from_power, averaged_power};
    use std::f64::consts::PI;

    /// An acceleration of sines; its spectrum as the diagnosis makes it.
    fn spectrum_of(lines: &[(f64, f64)], fs: f64, n: usize) -> Spectrum {
        let x: Vec<f64> =
            (0..n).map(|i| lines.iter().map(|(f, a)| a * (2.0 * PI * f * i as f64 / fs).sin()).sum::<f64>()).collect();
        let (p, seg) = averaged_power(&mut crate::signal::spectrum::Fft::new(), &x, 8192, 0.5, "test").unwrap();
        amplitude_from_power(&p, seg, fs)
    }

    #[test]
    fn velocity_rms_mm_s_works() {
        // a(t) = A sin(2 pi f t) integrates to a velocity of amplitude A / (2 pi f), RMS A / (2 pi f sqrt 2);
        // two lines in the band add in power; lines at 4 Hz and 1500 Hz lie outside 10-1000 Hz
        let fs = 10_000.0;
        let s = spectrum_of(&[(100.0, 2.0), (400.0, 3.0), (4.0, 5.0), (1500.0, 7.0)], fs, 80_000);
        let v = |a: f64, f: f64| a / (2.0 * PI * f) / 2f64.sqrt();
        let want = 1e3 * (v(2.0, 100.0).powi(2) + v(3.0, 400.0).powi(2)).sqrt();
        let got = velocity_rms_mm_s(&s, Measured::Acceleration(1.0), (10.0, 1000.0)).unwrap();
        // 0.5 %: the window's leakage of the 4 Hz line (5 bins from 10 Hz) and the frequency grid
        assert!((got / want - 1.0).abs() < 5e-3, "{got} against {want}");
        // the same spectrum read as velocity in mm/s: RMS of the in-band lines, no integration
        let got = velocity_rms_mm_s(&s, Measured::Velocity(1e-3), (10.0, 1000.0)).unwrap();
        let want = (2.0f64.powi(2) / 2.0 + 3.0f64.powi(2) / 2.0).sqrt();
        assert!((got / want - 1.0).abs() < 5e-3, "{got} against {want}");
        // a band beyond the Nyquist frequency cannot be measured
        assert!(velocity_rms_mm_s(&s, Measured::Velocity(1.0), (10.0, 6000.0)).is_none());
    }

    #[test]
    fn zones_follow_the_boundaries() {
        let c = MachineClass::from_name("group2-rigid").unwrap();
        assert_eq!(c.zone(1.0), Zone::A);
        assert_eq!(c.zone(1.4), Zone::B);
        assert_eq!(c.zone(4.4), Zone::C);
        assert_eq!(c.zone(9.0), Zone::D);
        assert_eq!(c.name(), "group2-rigid");
        assert!(measured_from_unit("m/s^2").is_some() && measured_from_unit("V").is_none());
    }
}
