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
