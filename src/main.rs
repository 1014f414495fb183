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
    if cli.reads_recordings() {
        keep_freed_memory();
    }
    // a panic is a bug: its location is kept for the one error line (a batch reports it for the recording
    // that caused it and goes on), never a backtrace, and never a success code
    std::panic::set_hook(Box::new(|info| {
        if let Some(l) = info.location() {
            gearvib::jobs::note_panic(l.to_string());
        }
    }));
    match std::panic::catch_unwind(|| gearvib::cli::run(cli)) {
        Ok(Ok(code)) => ExitCode::from(code),
        Ok(Err(e)) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Ok(Err(e)) => {
            eprintln!("gearvib: error: {e}");
            ExitCode::from(2)
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".into());
            let at = gearvib::jobs::last_panic_location().unwrap_or_default();
            eprintln!("gearvib: error: internal error at {at}: {what} (a bug in gearvib: please report it)");
            ExitCode::from(2)
        }
    }
}

/// glibc's allocator by default hands every freed block of more than 128 KiB (adaptively up to 32 MiB)
/// back to the system, trims each arena's top beyond 128 KiB, and gives each thread an arena of its own:
/// the diagnosis of a long recording, which allocates and frees record-long buffers from several
/// threads, then spends a fifth of its time in page faults and TLB flushes. One arena that keeps up to
/// 64 MiB of freed memory for reuse takes that away (60 s x 4 channels: 0.27 -> 0.23 s, 99 -> 91 MB
/// peak). Not for the solvers: their many small allocations from every thread contend for one arena (a
/// 2000-point sweep 20 % slower).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    const M_TRIM_THRESHOLD: i32 = -1;
    const M_MMAP_THRESHOLD: i32 = -3;
    const M_ARENA_MAX: i32 = -8;
    unsafe extern "C" {
        fn mallopt(param: i32, value: i32) -> i32;
    }
    // SAFETY: mallopt only changes the allocator's parameters; it is called before any other thread
    // exists, so no allocation runs concurrently with it.
    unsafe {
        mallopt(M_ARENA_MAX, 1);
        mallopt(M_MMAP_THRESHOLD, 32 << 20);
        mallopt(M_TRIM_THRESHOLD, 64 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}
