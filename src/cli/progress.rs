//! Progress on stderr, only when stderr is a terminal (indicatif).

use std::io::IsTerminal;

/// A spinner with a message, or nothing when stderr is not a terminal.
pub fn spinner() -> Option<indicatif::ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let pb = indicatif::ProgressBar::new_spinner();
        pb.enable_steady_tick(std::time::Duration::from_millis(120));
        pb
    })
}

/// A bar of `len` steps, or nothing when stderr is not a terminal.
pub fn bar(len: u64) -> Option<indicatif::ProgressBar> {
    std::io::stderr().is_terminal().then(|| indicatif::ProgressBar::new(len))
}
