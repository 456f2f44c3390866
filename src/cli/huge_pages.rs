//! Transparent huge pages while a big level is read, and only then.
//!
//! The binary's jemalloc asks for huge pages for all its memory (`main.rs`). Reading a big level
//! is where they pay: the importer's parsed document and meshes are hundreds of thousands of new
//! allocations, and faulting their pages in 4 KB at a time was a ninth of a 10 000-room
//! conversion's CPU (huge pages: import 0.40 → 0.32 CPU s, tags 0.11 → 0.08). Elsewhere they
//! only cost room: a small level's process grew from 13 to 21 MB, a 1 000-room one's from 37
//! to 48 MB, and the PVS methods' matrices by 40 MB at 10 000 rooms, for no time gained. So the
//! process runs with them turned off (Linux's `PR_SET_THP_DISABLE`, which wins over an
//! allocator's request), and reading a file of at least [`BIG`] bytes turns them on until the
//! level is read and tagged. Elsewhere than Linux this does nothing.

use std::path::Path;
use std::sync::Mutex;

/// Reads under way (a batch converts several files at once): huge pages are on while any is.
static READING: Mutex<usize> = Mutex::new(0);

/// Files smaller than this are read without huge pages (the size from which the importer also
/// reads a file on every thread).
pub const BIG: u64 = 16 << 20;

/// Huge pages on until dropped, when it was made for a big file.
#[must_use]
pub struct Reading(bool);

/// Turns huge pages on while the level at `path` is read, if it is a file of at least [`BIG`]
/// bytes (and leaves them on until the last such read under way ends).
pub fn reading(path: &Path) -> Reading {
    let big = std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() >= BIG);
    if big {
        let mut n = READING.lock().unwrap_or_else(|e| e.into_inner());
        *n += 1;
        if *n == 1 {
            set(true);
        }
    }
    Reading(big)
}

impl Drop for Reading {
    fn drop(&mut self) {
        if self.0 {
            let mut n = READING.lock().unwrap_or_else(|e| e.into_inner());
            *n -= 1;
            if *n == 0 {
                set(false);
            }
        }
    }
}

/// Turns huge pages off for the process (its state between reads).
pub fn off() {
    set(false);
}

fn set(on: bool) {
    #[cfg(target_os = "linux")]
    // SAFETY: PR_SET_THP_DISABLE only sets or clears a flag of this process's memory map; the
    // unused arguments must be zero. A kernel that refuses it leaves things as they were.
    unsafe {
        libc::prctl(libc::PR_SET_THP_DISABLE, libc::c_ulong::from(!on), 0, 0, 0);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = on;
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    /// The flag the kernel reports follows the calls, and a guard for a small file changes
    /// nothing.
    #[test]
    fn the_process_flag_follows_the_guard() {
        // SAFETY: PR_GET_THP_DISABLE takes no argument and reads a flag.
        let disabled = || unsafe { libc::prctl(libc::PR_GET_THP_DISABLE, 0, 0, 0, 0) };
        super::off();
        assert_eq!(disabled(), 1);
        let dir = tempfile::tempdir().unwrap();
        let small = dir.path().join("small.glb");
        std::fs::write(&small, b"glTF").unwrap();
        let big = dir.path().join("big.glb");
        std::fs::File::create(&big)
            .unwrap()
            .set_len(super::BIG)
            .unwrap();
        {
            let _g = super::reading(&small);
            assert_eq!(disabled(), 1);
        }
        {
            let _g = super::reading(&big);
            assert_eq!(disabled(), 0);
            // A second read, ending first, leaves them on for the one still under way.
            let second = super::reading(&big);
            drop(second);
            assert_eq!(disabled(), 0);
        }
        assert_eq!(disabled(), 1);
    }
}
