//! gearvib binary: parse arguments, run, map errors to exit codes (0 ok, 1 fault with --fail-on, 2 error).
//! A closed standard output (`gearvib ... | head`) is not an error: the run ends quietly with code 0. An
//! interrupted run removes its temporary files.

use std::process::ExitCode;

fn main() -> ExitCode {
    // SIGINT, SIGTERM, SIGHUP: remove the temporary files of outputs not yet in place, then stop (130 as a
    // shell reports an interrupt). Installed before the first temporary file only: the handler's thread
    // costs about 0.3 ms of a 5 ms run that writes nothing. If it cannot be installed the run goes on.
    gearvib::io::before_first_temporary(|| {
        let _ = ctrlc::set_handler(|| {
            gearvib::io::remove_temporaries();
            std::process::exit(130);
        });
    });
    let cli = gearvib::cli::parse_args();
    match gearvib::cli::run(cli) {
        Ok(code) => ExitCode::from(code),
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gearvib: error: {e}");
            ExitCode::from(2)
        }
    }
}
