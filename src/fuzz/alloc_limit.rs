//! An allocator for fuzz binaries that refuses absurd allocations: a loader must size its
//! buffers from what the file holds, never from a header's claim alone.
//!
//! Install it in a test or bench binary:
//! `#[global_allocator] static A: glint::fuzz::LimitAlloc = glint::fuzz::LimitAlloc;`
//! A single request over [`LIMIT`] bytes writes the input being run to
//! `glint-fuzz-oversize-<target>.bin` in the temporary folder, prints its path, and then
//! fails, which aborts the process: the run stops with the culprit saved.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Mutex;

/// Largest single allocation, bytes. Fuzz inputs are at most 1 MiB.
pub const LIMIT: usize = 256 << 20;

/// The input running on this thread: (input, its length, target name, its length).
type Current = (*const u8, usize, *const u8, usize);

thread_local! {
    static CURRENT: Cell<Current> = const { Cell::new((std::ptr::null(), 0, std::ptr::null(), 0)) };
}

/// The input that started last on any thread (addresses as integers): what a loader's
/// helper threads (a decoder's thread pool) work for.
static LAST: Mutex<Option<(usize, usize, usize, usize)>> = Mutex::new(None);

/// Records the input about to run on this thread (the slice must outlive the run).
pub(crate) fn set_current(target: &'static str, input: &[u8]) {
    let c = (input.as_ptr(), input.len(), target.as_ptr(), target.len());
    CURRENT.with(|cur| cur.set(c));
    if let Ok(mut last) = LAST.lock() {
        *last = Some((c.0 as usize, c.1, c.2 as usize, c.3));
    }
}

/// Forgets the input (it is about to be freed).
pub(crate) fn clear_current() {
    CURRENT.with(|c| c.set((std::ptr::null(), 0, std::ptr::null(), 0)));
    if let Ok(mut last) = LAST.lock() {
        *last = None;
    }
}

/// The system allocator with a ceiling on a single allocation (see the module docs).
pub struct LimitAlloc;

impl LimitAlloc {
    #[cold]
    fn oversize(size: usize) {
        let mut current =
            CURRENT
                .try_with(|c| c.get())
                .unwrap_or((std::ptr::null(), 0, std::ptr::null(), 0));
        if current.0.is_null()
            && let Some(l) = LAST.try_lock().ok().and_then(|l| *l)
        {
            current = (l.0 as *const u8, l.1, l.2 as *const u8, l.3);
        }
        let (ptr, len, tptr, tlen) = current;
        if ptr.is_null() {
            eprintln!("glint fuzz: an allocation of {size} bytes outside a fuzz input");
            return;
        }
        // SAFETY: the driver keeps the input alive while it is recorded.
        let input = unsafe { std::slice::from_raw_parts(ptr, len) };
        // SAFETY: a `&'static str` recorded by `set_current`.
        let target =
            unsafe { std::str::from_utf8_unchecked(std::slice::from_raw_parts(tptr, tlen)) };
        let path = std::env::temp_dir().join(format!("glint-fuzz-oversize-{target}.bin"));
        let _ = std::fs::write(&path, input);
        eprintln!(
            "glint fuzz: target {target} asked for {size} bytes (limit {LIMIT}); input saved to {}",
            path.display()
        );
    }
}

// SAFETY: forwards to `System`; refusing a request (null) is allowed by `GlobalAlloc`.
unsafe impl GlobalAlloc for LimitAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > LIMIT {
            Self::oversize(layout.size());
            return std::ptr::null_mut();
        }
        // SAFETY: same contract.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > LIMIT {
            Self::oversize(layout.size());
            return std::ptr::null_mut();
        }
        // SAFETY: same contract.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > LIMIT {
            Self::oversize(new_size);
            return std::ptr::null_mut();
        }
        // SAFETY: same contract.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}
