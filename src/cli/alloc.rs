//! The binary's allocator: jemalloc, on Unix. The pipeline makes millions of small allocations
//! on every thread, and glibc's malloc spent an eighth of a big conversion's CPU in them;
//! jemalloc converts a 10 000-room building about 15% faster with a lower peak
//! (docs/performance.md). The library leaves the choice to its callers (and has no unsafe code);
//! the benchmark's floor (`portcullis-floor`) runs on the system allocator. Also
//! [`release_free_memory`], which `convert` and `bench` call between stages.

#[cfg(unix)]
#[global_allocator]
static GLOBAL: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

/// A C string's address, as jemalloc reads its `malloc_conf` (a `const char *`).
#[cfg(unix)]
#[repr(transparent)]
pub struct CStrPtr(*const std::ffi::c_char);

// SAFETY: it points at a string literal, never written.
#[cfg(unix)]
unsafe impl Sync for CStrPtr {}

/// jemalloc's options, read when it starts: freed pages go back to the system after 0.3 s
/// (its default of 10 s kept a big conversion's freed stages resident, 10% over glibc's
/// peak), and none are kept in the lazily-freed state in between. 0.1 s gave pages back that
/// the same stage faulted in again a moment later, and the kernel's zeroing of them was a
/// tenth of a 10 000-room conversion's CPU; with 0.3 s its median time is 5% lower for a peak
/// of 236 MB against 216 MB.
///
/// Its memory is asked to be backed by transparent huge pages where the system gives them on
/// request (Linux's `madvise` setting, the usual default), and the process lets them be used
/// only while a big level is read ([`super::huge_pages`]): the importer's memory is new pages
/// faulted in a few KB at a time, and the kernel's zeroing and fault handling of them were a
/// ninth of a big conversion's CPU. `_RJEM_MALLOC_CONF=thp:default` in the environment turns
/// them off.
#[cfg(unix)]
#[allow(non_upper_case_globals)]
#[export_name = "_rjem_malloc_conf"]
pub static malloc_conf: CStrPtr =
    CStrPtr(c"dirty_decay_ms:300,muzzy_decay_ms:0,thp:always".as_ptr());

/// Hands the heap a stage freed (portals, the PVS) back to the system before the next
/// allocates its own. jemalloc returns freed pages by itself after 0.3 s ([`malloc_conf`]), so
/// this trims only what C code allocated through glibc's malloc, which keeps a freed heap
/// otherwise: there the next stage's large blocks did not always fit in it (on a big level,
/// 30 MB more at the export after a PVS). Nothing where the C library is not glibc.
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free pages of the allocator's heap to the system.
    unsafe {
        libc::malloc_trim(0);
    }
}
