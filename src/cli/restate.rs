//! Library errors that a flag caused, restated in terms of that flag: the library never names a flag,
//! the command line matches its typed errors to the flags that gave the values.

use super::CliError;
use crate::Error;
use crate::jobs::{ChannelRole, Given, JobError};

/// Library errors that a flag caused, restated with that flag.
pub(super) fn restate_for_flags(e: Error) -> Error {
    match e {
        Error::Job(JobError::Channel { file, role, index, count }) => {
            let flag = match role {
                ChannelRole::Vibration => "--channel",
                ChannelRole::Tachometer => "--tacho-channel",
            };
            CliError::flag(&format!("{flag} {index}"), format!("{file} has {count} channel(s), numbered from 1"))
        }
        Error::Job(JobError::NoSampleRate { file, for_speed: true }) => CliError::flag(
            "--rpm/--shaft-hz",
            format!("{file} has no sample rate (no time column); give it with --fs"),
        ),
        Error::Job(JobError::NoSampleRate { file, for_speed: false }) => Error::Job(JobError::Input {
            file,
            message: "no sample rate: the file has no time column; pass --fs HZ, or --fs-unknown to analyse in shaft orders only".into(),
        }),
        Error::Job(JobError::SampleRateConflict { file, given_hz, file_hz }) => CliError::flag(
            &format!("--fs {given_hz}"),
            format!("contradicts the {file_hz} Hz sample rate of {file}; add --fs-override if the file's rate is wrong"),
        ),
        Error::Job(JobError::Aliasing { file, message }) => {
            Error::Job(JobError::Aliasing { file, message: format!("{message} or pass --allow-aliasing") })
        }
        Error::Job(JobError::Value { what, message }) => match flag_of(what) {
            Some(flag) => CliError::flag(flag, message),
            None => Error::Job(JobError::Value { what, message }),
        },
        Error::Job(JobError::Missing { file, message, give }) => match flag_of(give) {
            Some(flag) => Error::Job(JobError::Input { file, message: format!("{message} ({flag})") }),
            None => Error::Job(JobError::Input { file, message }),
        },
        Error::Job(JobError::Parameter { scene, name, message }) => {
            CliError::flag(&format!("--param {name}"), format!("{scene}: {message}"))
        }
        other => other,
    }
}

/// With a profile (`profile`, its path), the errors its values caused restated with its field: no flag
/// gave them (its `processing.fs_hz` of -5 was blamed on `--fs`). A sample rate given with `--fs` beside
/// the profile (`fs_given`) stays the flag's.
pub(super) fn restate_for_profile(e: Error, profile: Option<&str>, fs_given: bool) -> Error {
    let Some(profile) = profile else { return e };
    let field = |name: &str, message: String| -> Error {
        Error::Job(JobError::Input { file: profile.to_string(), message: format!("field `{name}`: {message}") })
    };
    match e {
        Error::Job(JobError::Channel { file, role, index, count }) => {
            let name = match role {
                ChannelRole::Vibration => "processing.channel",
                ChannelRole::Tachometer => "processing.tacho_channel",
            };
            field(name, format!("channel {index}: {file} has {count} channel(s), numbered from 1"))
        }
        Error::Job(JobError::Value { what: Given::SampleRate, message }) if !fs_given => {
            field("processing.fs_hz", message)
        }
        Error::Job(JobError::Value { what: Given::ShaftSpeed, message }) => field("processing.shaft_hz", message),
        Error::Job(JobError::Value { what: Given::Teeth, message }) => field("processing.teeth", message),
        other => other,
    }
}

/// The flag that gives a value, where one flag does.
pub(super) fn flag_of(what: Given) -> Option<&'static str> {
    Some(match what {
        Given::SampleRate => "--fs",
        Given::ShaftSpeed => "--rpm/--shaft-hz",
        Given::Teeth => "--teeth",
        Given::PinionOrders => "--pinion-orders",
        Given::WheelOrders => "--wheel-orders",
        Given::Orders => "--pinion-orders/--wheel-orders",
        Given::PitWidth => "--pit-width",
        Given::SweepSteps => "--steps",
        Given::SweepRange | Given::SweepValues | Given::Baseline => return None,
    })
}
