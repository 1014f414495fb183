//! What the seeded mutation tests share: a global allocator that records the largest single request, a
//! small seeded generator, and the check every mutant's run must pass.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Largest single allocation seen since the last reset (bytes).
pub static LARGEST: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, recording the largest single request in [`LARGEST`]; a test crate installs it
/// with `#[global_allocator] static ALLOCATOR: Counting = Counting;`.
pub struct Counting;

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// xorshift64: seeded, reproducible, enough to pick bytes and lengths.
pub struct XorShift(pub u64);

impl XorShift {
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// A number in 0..n (0 when n is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Runs one mutant: `f` gets the input's path and returns Ok or the error's message. A panic, an error
/// that does not name its input or spans lines, a single allocation over `ceiling` bytes or a run over
/// `hang_s` seconds fails the test. Returns whether `f` gave a result.
pub fn case(
    path: &Path,
    ceiling: usize,
    hang_s: f64,
    f: impl FnOnce(&Path) -> Result<(), String> + std::panic::UnwindSafe,
) -> bool {
    LARGEST.store(0, Ordering::Relaxed);
    let started = std::time::Instant::now();
    let p = path.to_path_buf();
    let outcome = std::panic::catch_unwind(move || f(&p));
    let took = started.elapsed().as_secs_f64();
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let ok = match outcome {
        Err(_) => panic!("{name}: panicked"),
        Ok(Err(msg)) => {
            assert!(msg.contains(&name), "{name}: error does not name its input: {msg}");
            assert!(!msg.contains('\n'), "{name}: multi-line error: {msg}");
            false
        }
        Ok(Ok(())) => true,
    };
    let largest = LARGEST.load(Ordering::Relaxed);
    assert!(largest <= ceiling, "{name}: a single allocation of {largest} bytes");
    assert!(took < hang_s, "{name}: {took:.1} s");
    ok
}
