//! The binary's top-level catch (`gearvib::cli::guarded`, which `main` runs every command through with
//! the hook of `gearvib::cli::quiet_panics`): a panic anywhere in a command, in its own thread or in a
//! worker's, ends as one line on standard error naming where it happened, with exit code 2, never a
//! backtrace and never a success code; errors and a closed standard output keep their codes. No hidden
//! trigger in the binary: the wrapper itself is run on closures that panic. One test in this binary, since
//! the panic hook is the process's.

use gearvib::Error;
use gearvib::cli::{guarded, quiet_panics};

#[test]
fn a_panic_anywhere_in_a_command_is_one_line_with_exit_code_2() {
    quiet_panics();

    // a panic in the command's own thread: its message and this file's line, on one line
    let line = line!() + 1;
    let (code, msg) = guarded(|| panic!("index out of bounds: the len is 33 but the index is 38"));
    let msg = msg.expect("a line for standard error");
    assert_eq!(code, 2, "{msg}");
    assert!(msg.starts_with("gearvib: error: internal error at "), "{msg}");
    assert!(msg.contains(&format!("panic_catch.rs:{line}:")), "the panic's location: {msg}");
    assert!(msg.contains("the len is 33 but the index is 38") && msg.contains("a bug in gearvib"), "{msg}");
    assert!(!msg.contains('\n'), "{msg}");

    // in a worker thread of the pool the analyses run on, after partial work: still code 2, one line
    let (code, msg) = guarded(|| {
        use rayon::prelude::*;
        let sums: Vec<u64> = (0..64u64)
            .into_par_iter()
            .map(|i| if i == 37 { panic!("worker {i} failed\nsecond line") } else { i })
            .collect();
        Ok(u8::try_from(sums.len()).unwrap_or(0))
    });
    let msg = msg.expect("a line for standard error");
    assert_eq!(code, 2, "{msg}");
    assert!(msg.contains("worker 37 failed second line"), "one line, the message kept: {msg}");
    assert!(!msg.contains('\n'), "{msg}");
    assert!(msg.contains("panic_catch.rs:"), "{msg}");

    // a panic with a payload that is not text
    let (code, msg) = guarded(|| std::panic::panic_any(42u32));
    assert_eq!(code, 2);
    assert!(msg.unwrap().contains("internal error at"), "a location even without a message");

    // the ordinary outcomes keep their codes: the command's own, an error's 2, a closed pipe's quiet 0
    assert_eq!(guarded(|| Ok(1)), (1, None));
    assert_eq!(guarded(|| Ok(0)), (0, None));
    let broken = std::io::Error::from(std::io::ErrorKind::BrokenPipe);
    assert_eq!(guarded(|| Err(Error::from(gearvib::cli::CliError::Stdout(broken)))), (0, None));
    let (code, msg) = guarded(|| {
        Err(Error::from(gearvib::cli::CliError::Flag { flag: "--rpm".into(), message: "must be positive".into() }))
    });
    assert_eq!((code, msg.as_deref()), (2, Some("gearvib: error: --rpm: must be positive")));
}
