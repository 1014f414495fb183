//! The condition indicators, one enum for every place that names them: the JSON keys, the labels of tables
//! and images, what a rise means, and the scale the baseline scores them on. Definitions are those of
//! `../shared/reference/diagnostics.md`.

use serde::{Deserialize, Serialize};

/// A condition indicator of a gear's time-synchronous average (TSA), or of the raw signal. Every one rises
/// with damage; the baseline scores only a rise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Indicator {
    /// Root mean square of the centred average (unit of the signal).
    Rms,
    /// Normalised fourth moment of the average (3 for Gaussian noise).
    Kurtosis,
    /// Peak over RMS of the centred average.
    CrestFactor,
    /// Peak-to-peak of the average over the sum of its mesh-harmonic amplitudes.
    Fm0,
    /// Kurtosis of the difference signal (the residual without the first-order sidebands).
    Fm4,
    /// Normalised sixth moment of the difference signal.
    M6a,
    /// Normalised eighth moment of the difference signal.
    M8a,
    /// Kurtosis of the residual signal (the average without shaft and mesh lines).
    Na4,
    /// Fourth moment of the residual over the square of the baseline's residual variance (NA4*).
    Na4Star,
    /// Energy ratio: RMS of the difference signal over RMS of the regular signal.
    Er,
    /// Sideband index: mean amplitude of the first-order sidebands of the first mesh line (unit).
    Si,
    /// Sideband level factor: the first-order sidebands' sum over the average's RMS.
    Slf,
    /// Sideband energy ratio: sidebands (orders +-1..6) over the mesh line around the first mesh harmonic.
    Ser,
    /// First-order sideband ratio: the first sidebands' energy over the mesh lines' energy, summed over
    /// every mesh harmonic.
    Sbr,
    /// RMS distance of the average's log order spectrum from the baseline's, dB.
    SpectralChange,
    /// Second central moment of the residual signal (unit^2), for NA4*.
    ResidualM2,
    /// Fourth central moment of the residual signal (unit^4), for NA4*.
    ResidualM4,
}

/// Where an indicator is scored: ratios of moments and energies vary by factors between blocks (their
/// block-to-block spread is skewed, M6A from 11 to 25 around 13 on a real healthy gearbox), so they are
/// scored on their logarithm; the spectral change is already a distance in dB.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// The value itself.
    Linear,
    /// Its natural logarithm.
    Log,
}

impl Indicator {
    /// The indicators that take part in a verdict against a baseline, in the order they are scored.
    pub const DECIDING: [Indicator; 9] = [
        Self::Fm4,
        Self::M6a,
        Self::Na4Star,
        Self::Er,
        Self::Fm0,
        Self::Ser,
        Self::Sbr,
        Self::Si,
        Self::SpectralChange,
    ];

    /// The indicators of a gear's average printed in tables and written to the JSON.
    pub const TABLE: [Indicator; 13] = [
        Self::Fm0,
        Self::Fm4,
        Self::M6a,
        Self::M8a,
        Self::Na4,
        Self::Er,
        Self::Si,
        Self::Slf,
        Self::Ser,
        Self::Sbr,
        Self::Rms,
        Self::Kurtosis,
        Self::CrestFactor,
    ];

    /// The JSON key (lower case, `na4_star`).
    pub fn key(self) -> &'static str {
        match self {
            Self::Rms => "rms",
            Self::Kurtosis => "kurtosis",
            Self::CrestFactor => "crest_factor",
            Self::Fm0 => "fm0",
            Self::Fm4 => "fm4",
            Self::M6a => "m6a",
            Self::M8a => "m8a",
            Self::Na4 => "na4",
            Self::Na4Star => "na4_star",
            Self::Er => "er",
            Self::Si => "si",
            Self::Slf => "slf",
            Self::Ser => "ser",
            Self::Sbr => "sbr",
            Self::SpectralChange => "spectral_change",
            Self::ResidualM2 => "residual_m2",
            Self::ResidualM4 => "residual_m4",
        }
    }

    /// The name shown to people (`NA4*`, `crest factor`).
    pub fn label(self) -> &'static str {
        match self {
            Self::Rms => "RMS",
            Self::Kurtosis => "kurtosis",
            Self::CrestFactor => "crest factor",
            Self::Fm0 => "FM0",
            Self::Fm4 => "FM4",
            Self::M6a => "M6A",
            Self::M8a => "M8A",
            Self::Na4 => "NA4",
            Self::Na4Star => "NA4*",
            Self::Er => "ER",
            Self::Si => "SI",
            Self::Slf => "SLF",
            Self::Ser => "SER",
            Self::Sbr => "SBR",
            Self::SpectralChange => "spectral change",
            Self::ResidualM2 => "residual m2",
            Self::ResidualM4 => "residual m4",
        }
    }

    /// A short column heading for fixed-width text tables (at most 10 characters).
    pub fn column(self) -> &'static str {
        match self {
            Self::CrestFactor => "crest",
            Self::SpectralChange => "spectral",
            other => other.key(),
        }
    }

    /// What a rise of the indicator means, in words.
    pub fn meaning(self) -> &'static str {
        match self {
            Self::Fm4 => "the difference signal is more impulsive",
            Self::M6a => "the difference signal has sharper peaks",
            Self::M8a => "the difference signal has still sharper peaks",
            Self::Na4 => "the residual signal is impulsive",
            Self::Na4Star => "the residual signal has grown and become impulsive",
            Self::Er => "more energy outside the regular mesh lines",
            Self::Fm0 => "the peak-to-peak of the average grew against the mesh lines",
            Self::Ser => "the sidebands around the mesh line have grown",
            Self::Sbr => "the first sidebands of every mesh harmonic have grown against the harmonics",
            Self::Si => "the first sidebands of the mesh line have grown",
            Self::Slf => "the first sidebands of the mesh line have grown against the average's RMS",
            Self::SpectralChange => "the order spectrum of the average has changed",
            Self::Rms => "the average's level has grown",
            Self::Kurtosis => "the average is more impulsive",
            Self::CrestFactor => "the average's peaks have grown against its RMS",
            Self::ResidualM2 => "the residual signal has grown",
            Self::ResidualM4 => "the residual signal's peaks have grown",
        }
    }

    /// The scale a baseline scores the indicator on.
    pub fn scale(self) -> Scale {
        match self {
            Self::SpectralChange => Scale::Linear,
            _ => Scale::Log,
        }
    }

    /// Whether the indicator scales with the absolute level of the signal (the others are ratios of the
    /// signal to itself): such an indicator cannot decide when the two sides' units differ or one is unknown.
    pub fn level_dependent(self) -> bool {
        matches!(self, Self::Na4Star | Self::Si | Self::SpectralChange)
    }

    /// Whether the indicator alone makes a gear at most suspect, and does not count towards the indicators
    /// that together make it faulty: SBR reads a once-per-revolution modulation, which a load fluctuating
    /// near the shaft's rate puts on a healthy gear too (a healthy two-stage recording of the test
    /// generator, its output shaft modulated so, stood 5-6 spreads over its baseline; a healthy 18/31 wheel
    /// against one sibling 4.3 spreads, beside its FM0), so it calls for a look, not a stop.
    pub fn supporting(self) -> bool {
        matches!(self, Self::Sbr)
    }

    /// Whether the indicator is a ratio of what is not the mesh to the mesh lines (FM0: the average's
    /// peak-to-peak over the sum of its mesh-harmonic amplitudes; ER: the difference signal's RMS over the
    /// regular signal's): a weaker mesh (a lighter load, another operating point) raises them together, so
    /// two of them at their limit are one piece of evidence, not corroboration. A healthy 18/31 wheel of the
    /// test generator against one sibling (tests/unseen_machines.rs, more machines, with the tachometer)
    /// stood at FM0 6.5 and ER 5.4 spreads, nothing else moved, and was called faulty on the two.
    pub fn mesh_ratio(self) -> bool {
        matches!(self, Self::Fm0 | Self::Er)
    }

    /// Whether the indicator measures the sidebands at the gear's own shaft spacing around its mesh harmonics
    /// (SBR, SER, SI): a modulation once per the gear's revolution.
    pub fn sideband(self) -> bool {
        matches!(self, Self::Sbr | Self::Ser | Self::Si)
    }

    /// Whether the indicator sees a local fault (one or a few teeth): a peak in the difference signal.
    pub fn local(self) -> bool {
        matches!(self, Self::Fm4 | Self::M6a)
    }

    /// Every indicator.
    pub const ALL: [Indicator; 17] = [
        Self::Rms,
        Self::Kurtosis,
        Self::CrestFactor,
        Self::Fm0,
        Self::Fm4,
        Self::M6a,
        Self::M8a,
        Self::Na4,
        Self::Na4Star,
        Self::Er,
        Self::Si,
        Self::Slf,
        Self::Ser,
        Self::Sbr,
        Self::SpectralChange,
        Self::ResidualM2,
        Self::ResidualM4,
    ];
}

impl std::fmt::Display for Indicator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

/// Indicators by name: a small map with the indicators as keys (serialised with their JSON keys).
pub type Indicators = std::collections::BTreeMap<Indicator, f64>;

#[cfg(test)]
mod tests {
    use super::*;

    /// The JSON key serde writes is the one `key` names, and it reads back (profiles store them).
    #[test]
    fn keys_round_trip_through_json() {
        for i in Indicator::ALL {
            let json = serde_json::to_string(&i).unwrap();
            assert_eq!(json, format!("\"{}\"", i.key()));
            assert_eq!(serde_json::from_str::<Indicator>(&json).unwrap(), i);
        }
        for i in Indicator::TABLE {
            assert!(i.column().len() <= 10, "{i:?}");
        }
        let m: Indicators = [(Indicator::Na4Star, 1.5), (Indicator::Fm4, 3.0)].into_iter().collect();
        let json = serde_json::to_string(&m).unwrap();
        assert!(json.contains("\"na4_star\":1.5"), "{json}");
        assert_eq!(serde_json::from_str::<Indicators>(&json).unwrap(), m);
    }
}
