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
    gearvib::cli::quiet_panics();
    let (code, line) = gearvib::cli::guarded(|| gearvib::cli::run(cli));
    if let Some(line) = line {
        eprintln!("{line}");
    }
    ExitCode::from(code)
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
