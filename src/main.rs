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

/// The system allocator, asking the kernel for 2 MiB pages (transparent huge pages, `madvise` mode) in the
/// 2 MiB-aligned interior of every block of 4 MiB or more before it is first touched: a record-long buffer
/// (a 60 s channel at 51.2 kHz is 12 MB in f32, twice that in f64) then faults in 512
/// times fewer pages. 60 s x 4 channels: 0.31 -> 0.28 s, system time 0.07 -> 0.05 s (medians of 7 on the
/// 2-core VM). Where the kernel has no such pages the advice is refused and nothing changes.
#[cfg(all(target_os = "linux", target_env = "gnu", any(target_arch = "x86_64", target_arch = "aarch64")))]
struct HugePageHint;

#[cfg(all(target_os = "linux", target_env = "gnu", any(target_arch = "x86_64", target_arch = "aarch64")))]
#[global_allocator]
static ALLOCATOR: HugePageHint = HugePageHint;

#[cfg(all(target_os = "linux", target_env = "gnu", any(target_arch = "x86_64", target_arch = "aarch64")))]
mod huge_pages {
    use std::alloc::{GlobalAlloc, Layout, System};

    /// Smallest block advised (two huge pages: at least one aligned one lies inside).
    const ADVISED_FROM: usize = 4 << 20;
    /// The huge page size, bytes.
    const HUGE_PAGE: usize = 2 << 20;
    /// `MADV_HUGEPAGE` of Linux's `asm-generic/mman-common.h` (x86-64 and aarch64).
    const MADV_HUGEPAGE: i32 = 14;

    unsafe extern "C" {
        fn madvise(addr: *mut std::ffi::c_void, len: usize, advice: i32) -> i32;
    }

    /// Advises huge pages for the aligned interior of the `size` bytes at `p` (a failure is ignored: the
    /// pages are then ordinary ones).
    fn advise(p: *mut u8, size: usize) {
        if p.is_null() || size < ADVISED_FROM {
            return;
        }
        let start = (p as usize).next_multiple_of(HUGE_PAGE);
        let end = (p as usize + size) / HUGE_PAGE * HUGE_PAGE;
        if end > start {
            // SAFETY: the range lies inside a block the allocator just handed out; the advice changes how
            // its pages are backed, never their contents.
            unsafe { madvise(start as *mut std::ffi::c_void, end - start, MADV_HUGEPAGE) };
        }
    }

    // SAFETY: every call goes to the system allocator with the same arguments; `advise` only adds a hint on
    // the block it returned.
    unsafe impl GlobalAlloc for super::HugePageHint {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            // SAFETY: as the caller's contract for `GlobalAlloc::alloc`
            let p = unsafe { System.alloc(layout) };
            advise(p, layout.size());
            p
        }
        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            // SAFETY: as the caller's contract for `GlobalAlloc::alloc_zeroed`
            let p = unsafe { System.alloc_zeroed(layout) };
            advise(p, layout.size());
            p
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: as the caller's contract for `GlobalAlloc::dealloc`
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            // SAFETY: as the caller's contract for `GlobalAlloc::realloc`
            let p = unsafe { System.realloc(ptr, layout, new_size) };
            advise(p, new_size);
            p
        }
    }
}
