//! gearvib binary: parse arguments, run, map errors to exit codes (0 ok, 1 fault with --fail-on, 2 error).

use std::process::ExitCode;

/// A reader that closed the pipe early (`gearvib ... | head`) is not an error of ours.
fn is_broken_pipe(info: &std::panic::PanicHookInfo<'_>) -> bool {
    info.payload()
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| info.payload().downcast_ref::<&str>().copied())
        .is_some_and(|m| m.contains("failed printing to stdout") && m.contains("Broken pipe"))
}

fn main() -> ExitCode {
    std::panic::set_hook(Box::new(|info| {
        if !is_broken_pipe(info) {
            eprintln!("gearvib: internal error (please report): {info}");
        }
    }));
    let cli = gearvib::cli::parse_args();
    match std::panic::catch_unwind(|| gearvib::cli::run(cli)) {
        Ok(Ok(code)) => ExitCode::from(code),
        Ok(Err(e)) => {
            eprintln!("gearvib: error: {e}");
            ExitCode::from(2)
        }
        Err(_) => ExitCode::from(2),
    }
}
