//! Freeing big structures off the critical path.
//!
//! A big level's cells, portals and indexes are millions of small allocations; freeing them
//! one by one is serial work the next stage (or the next file of a batch, or the process's
//! exit) need not wait for.

/// Frees `v` on a thread of its own (here, if no thread can be had).
pub fn drop_elsewhere<T: Send + 'static>(v: T) {
    // On failure the closure, and `v` with it, is dropped here.
    let _ = std::thread::Builder::new().spawn(move || drop(v));
}
