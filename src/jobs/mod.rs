//! Jobs: the library functions behind each command. Each takes a job description (paths and options,
//! never command-line flags), does all the work, writes the files it was asked for, and returns typed
//! results for the caller to print.
//!
//! - [`simulate`]: periodic steady state of a scene, its orders, optional signal file ([`synth`]) and report;
//!   [`simulate::stability`] for the Floquet analysis alone.
//! - [`sweep`]: Floquet analysis and line amplitudes over a parameter range (all cores).
//! - [`bench`](mod@bench): speed against error of every solver.
//! - [`diagnose`]: recordings -> speed, TSA, indicators, verdict against a baseline, model comparison.
//! - [`identify`]: a gear-pair scene fitted to a recording: tooth errors, path gains, a local fault.

pub mod bench;
pub mod diagnose;
pub mod identify;
pub mod simulate;
pub mod sweep;
pub mod synth;
pub mod train;

/// Where the last panic of this process happened (`file:line:column`), as the binary's panic hook
/// records it with [`note_panic`]: a panic caught as an internal error then says where.
static LAST_PANIC: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// Records where a panic happened (called from a panic hook).
pub fn note_panic(location: String) {
    *LAST_PANIC.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(location);
}

/// The location recorded by [`note_panic`] since the last call, if any.
pub fn last_panic_location() -> Option<String> {
    LAST_PANIC.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take()
}

/// The role a channel number plays in a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelRole {
    /// The vibration channel to analyse.
    Vibration,
    /// The tachometer channel.
    Tachometer,
}

impl std::fmt::Display for ChannelRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Vibration => "channel",
            Self::Tachometer => "tachometer channel",
        })
    }
}

/// A value given to a job, named in errors about it (the command line names its flag, the Python bindings
/// its keyword).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Given {
    /// The sample rate, Hz.
    SampleRate,
    /// The shaft speed (rpm or Hz).
    ShaftSpeed,
    /// The gears' teeth.
    Teeth,
    /// The pinion orders an identification fits.
    PinionOrders,
    /// The wheel orders an identification fits.
    WheelOrders,
    /// The pinion and wheel orders together.
    Orders,
    /// The pit width of a local-fault search, tooth pitches.
    PitWidth,
    /// A sweep's range.
    SweepRange,
    /// A sweep's number of steps.
    SweepSteps,
    /// A sweep's list of values.
    SweepValues,
    /// The healthy recordings of a baseline.
    Baseline,
}

impl std::fmt::Display for Given {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::SampleRate => "sample rate",
            Self::ShaftSpeed => "shaft speed",
            Self::Teeth => "teeth",
            Self::PinionOrders => "pinion orders",
            Self::WheelOrders => "wheel orders",
            Self::Orders => "orders",
            Self::PitWidth => "pit width",
            Self::SweepRange => "sweep range",
            Self::SweepSteps => "sweep steps",
            Self::SweepValues => "sweep values",
            Self::Baseline => "baseline",
        })
    }
}

/// Errors of the job layer: an input that does not fit the job, or a result that cannot be trusted.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// An input file cannot be used for this job.
    #[error("{file}: {message}")]
    Input {
        /// The file.
        file: String,
        /// What is wrong, in terms of the file's content.
        message: String,
    },
    /// A requested channel does not exist in the file.
    #[error("{file}: {role} {index} does not exist: the file has {count} channel(s), numbered from 1")]
    Channel {
        /// The file.
        file: String,
        /// What the channel was asked for.
        role: ChannelRole,
        /// Requested 1-based index.
        index: usize,
        /// Channels in the file.
        count: usize,
    },
    /// The recording has no sample rate and the job needs one.
    #[error("{file}: no sample rate: the file has no time column and none was given{}", if *.for_speed { " (a given shaft speed in Hz needs it)" } else { "" })]
    NoSampleRate {
        /// The file.
        file: String,
        /// True when a given speed is what needs it.
        for_speed: bool,
    },
    /// A given sample rate contradicts the file's own (its header or time column).
    #[error(
        "{file}: the given sample rate {given_hz} Hz contradicts the file's {file_hz} Hz; say that it overrides the file to use it"
    )]
    SampleRateConflict {
        /// The file.
        file: String,
        /// The given rate, Hz.
        given_hz: f64,
        /// The file's rate, Hz.
        file_hz: f64,
    },
    /// The recording does not hold what the job needs, and a value given would supply it.
    #[error("{file}: {message}")]
    Missing {
        /// The file.
        file: String,
        /// What could not be found, and what would supply it, in words.
        message: String,
        /// The value to give.
        give: Given,
    },
    /// A given value is out of its meaningful range.
    #[error("{what}: {message}")]
    Value {
        /// The value that is wrong.
        what: Given,
        /// What is wrong.
        message: String,
    },
    /// A periodic solution or multipliers that cannot meet the scene's tolerance.
    #[error("{file}: {message}")]
    Untrusted {
        /// Scene file.
        file: String,
        /// What was refused and why.
        message: String,
    },
    /// Writing the signal would alias lines above half the sample rate.
    #[error("{file}: {message}")]
    Aliasing {
        /// Output file.
        file: String,
        /// Which lines alias.
        message: String,
    },
    /// A sweep parameter that the scene does not have.
    #[error("{scene}: parameter \"{name}\": {message}")]
    Parameter {
        /// Scene file.
        scene: String,
        /// Parameter name as given.
        name: String,
        /// What is wrong.
        message: String,
    },
}
