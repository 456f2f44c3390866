//! The `portcullis` binary: parse arguments, call the library, map the outcome to an exit code
//! (0 clean, 1 the level has errors, 2 the tool could not do its job).

mod cli;

/// The allocator: jemalloc, or the system's when `PORTCULLIS_ALLOCATOR=system`.
///
/// The pipeline makes millions of small allocations on every thread, and glibc's malloc spent
/// an eighth of a big conversion's CPU in them; jemalloc converts a 10 000-room building about
/// 15% faster with a lower peak (README, "Measured"). `bench` runs its floor, the gltf crate
/// alone, on the system allocator, as a program using only that crate would run.
#[cfg(unix)]
#[global_allocator]
static GLOBAL: alloc::Chosen = alloc::Chosen;

/// jemalloc's options, read when it starts: freed pages go back to the system after 0.3 s
/// (its default of 10 s kept a big conversion's freed stages resident, 10% over glibc's
/// peak), and none are kept in the lazily-freed state in between. 0.1 s gave pages back that
/// the same stage faulted in again a moment later, and the kernel's zeroing of them was a
/// tenth of a 10 000-room conversion's CPU. With 0.3 s its median time is 5% lower (eight runs
/// each, alternated: 1.165 s against 1.23 s) and its slow runs rarer, for a peak of 236 MB
/// against 216 MB; the fastest runs are the same (1.14 s and 1.12 s).
///
/// Its memory is asked to be backed by transparent huge pages where the system gives them on
/// request (Linux's `madvise` setting, the usual default), and the process lets them be used
/// only while a big level is read (`cli/huge_pages.rs`): the importer's memory is new pages
/// faulted in a few KB at a time, and the kernel's zeroing and fault handling of them were a
/// ninth of a big conversion's CPU. With huge pages a 10 000-room building converts 8% faster
/// (fastest of 9: 1.10 s against 1.20 s, 1.94 against 2.11 CPU s). `_RJEM_MALLOC_CONF=
/// thp:default` in the environment turns them off.
#[cfg(unix)]
#[allow(non_upper_case_globals)]
#[export_name = "_rjem_malloc_conf"]
pub static malloc_conf: alloc::CStrPtr =
    alloc::CStrPtr(c"dirty_decay_ms:300,muzzy_decay_ms:0,thp:always".as_ptr());

/// The environment variable that picks the system allocator (`system`); read once, at the
/// first allocation.
const ALLOCATOR_VAR: &str = "PORTCULLIS_ALLOCATOR";

#[cfg(unix)]
mod alloc {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::sync::atomic::{AtomicU8, Ordering};

    use tikv_jemallocator::Jemalloc;

    /// jemalloc, or the system allocator if the environment says so.
    pub struct Chosen;

    /// A C string's address, as jemalloc reads its `malloc_conf` (a `const char *`).
    #[repr(transparent)]
    pub struct CStrPtr(pub *const std::ffi::c_char);

    // SAFETY: it points at a string literal, never written.
    unsafe impl Sync for CStrPtr {}

    /// 0: not read yet, 1: the system's, 2: jemalloc.
    static WHICH: AtomicU8 = AtomicU8::new(0);

    fn system() -> bool {
        match WHICH.load(Ordering::Relaxed) {
            1 => true,
            2 => false,
            _ => {
                // getenv allocates nothing, and the first allocation is made before any other
                // thread exists; every later one sees the same answer.
                // SAFETY: a NUL-terminated name; the result is read before anything can
                // change the environment.
                let v = unsafe { libc::getenv(c"PORTCULLIS_ALLOCATOR".as_ptr()) };
                let sys = !v.is_null()
                    // SAFETY: getenv returns a NUL-terminated string when not null.
                    && unsafe { std::ffi::CStr::from_ptr(v) }.to_bytes() == b"system";
                WHICH.store(if sys { 1 } else { 2 }, Ordering::Relaxed);
                sys
            }
        }
    }

    // SAFETY: every call goes to one allocator, the same for the whole process (decided at
    // the first allocation), so memory is always freed by the allocator that gave it.
    unsafe impl GlobalAlloc for Chosen {
        unsafe fn alloc(&self, l: Layout) -> *mut u8 {
            if system() {
                System.alloc(l)
            } else {
                Jemalloc.alloc(l)
            }
        }
        unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
            if system() {
                System.alloc_zeroed(l)
            } else {
                Jemalloc.alloc_zeroed(l)
            }
        }
        unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
            if system() {
                System.dealloc(p, l)
            } else {
                Jemalloc.dealloc(p, l)
            }
        }
        unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
            if system() {
                System.realloc(p, l, n)
            } else {
                Jemalloc.realloc(p, l, n)
            }
        }
    }
}

use clap::Parser;

fn main() {
    // Rust ignores SIGPIPE, so a closed pipe (`portcullis vis big.prt | head`) would make the
    // next print fail; with the default action the process ends quietly, like `cat`.
    #[cfg(unix)]
    // SAFETY: called before any other thread exists; SIG_DFL is always a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    cli::huge_pages::off();
    let cli = match cli::Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    std::process::exit(cli::run(cli));
}
