//! Tests of the command line: every flag an error is restated with exists.

use super::restate::flag_of;
use super::*;
use crate::jobs::Given;
use clap::CommandFactory;

/// Every flag an error is restated with is a flag of some command (a renamed flag would otherwise leave
/// errors naming one that does not exist).
#[test]
fn every_flag_named_for_a_given_value_exists() {
    let cli = args::Cli::command();
    let longs: Vec<String> = cli
        .get_subcommands()
        .flat_map(|c| c.get_arguments().filter_map(|a| a.get_long().map(|l| format!("--{l}"))).collect::<Vec<_>>())
        .collect();
    let all = [
        Given::SampleRate,
        Given::ShaftSpeed,
        Given::Teeth,
        Given::PinionOrders,
        Given::WheelOrders,
        Given::Orders,
        Given::PitWidth,
        Given::SweepRange,
        Given::SweepSteps,
        Given::SweepValues,
        Given::Baseline,
    ];
    for what in all {
        for flag in flag_of(what).into_iter().flat_map(|f| f.split('/')) {
            assert!(longs.iter().any(|l| l == flag), "{what}: {flag} is no flag");
        }
    }
}
