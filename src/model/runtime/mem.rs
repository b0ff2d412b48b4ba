//! Memory given back between stages.
//!
//! A stage frees what only it needed (the reader's id registry and polygon arena, the rough
//! stage's work buffers), but glibc's allocator keeps freed heap pages in the process: the
//! next stage's large blocks (a BVH's nodes, a writer's index) are separate mappings and do
//! not reuse them, so the process's peak would be every stage's garbage plus the next
//! stage's work. [`give_back`] returns the free pages to the system (glibc's `malloc_trim`);
//! elsewhere it does nothing.

/// Models of at least this many assets give their free pages back between stages
/// ([`give_back_for`]); below it (a district of tens of thousands of assets) the pages freed
/// are few and the trim's time is not repaid, above it (a city of hundreds of thousands) it
/// lowers the peak.
pub const GIVE_BACK_MIN_ASSETS: usize = 200_000;

static ENABLED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

/// Whether the pipeline gives pages back between stages (`give_back_for`); on by
/// default. A program whose own heap should not be trimmed turns it off (it is process-wide:
/// `malloc_trim` acts on the whole process's heap).
pub fn set_give_back(enabled: bool) {
    ENABLED.store(enabled, std::sync::atomic::Ordering::Relaxed);
}

/// Whether [`give_back_for`] trims ([`set_give_back`]).
pub fn gives_back() -> bool {
    ENABLED.load(std::sync::atomic::Ordering::Relaxed)
}

/// [`give_back`] when a model of `assets` assets is large enough for it to pay
/// ([`GIVE_BACK_MIN_ASSETS`]) and giving back is on ([`set_give_back`]).
pub fn give_back_for(assets: usize) {
    if assets >= GIVE_BACK_MIN_ASSETS && gives_back() {
        give_back();
    }
}

/// Return the allocator's free pages to the system (glibc only; a no-op elsewhere).
///
/// ```
/// let v = vec![0u8; 1 << 20];
/// drop(v);
/// skylod::model::give_back();
/// ```
pub fn give_back() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory of the allocator's own arenas; it takes
    // the allocator's locks and has no precondition on the caller.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// The most [`reserve_heap`] reserves: under the 64 MiB of one glibc thread heap.
pub const RESERVE_MAX_BYTES: usize = 56 << 20;

/// Let the calling thread's allocator arena grow by about `bytes` in a few steps instead of
/// a page at a time (glibc only; a no-op elsewhere).
///
/// glibc's arena of a thread other than the main one is a heap whose writable part grows
/// with one `mprotect` call per allocation that crosses its top, by just what that
/// allocation needs: a reader making a city's polygons (millions of small blocks) pays a
/// system call per page of them (the paper district: about 5,600 per reading thread).
/// A heap never makes writable again what it made writable once, even after giving the
/// pages back. So the blocks of 120 KiB (below glibc's smallest threshold for a block of
/// its own mapping) allocated here and freed at once leave the heap writable up to `bytes`
/// more (at most `RESERVE_MAX_BYTES`) in one call per block; freed in order, they merge
/// into the heap's free top, whose pages glibc then gives back (none was ever touched but a
/// block's header). The memory used, and the process's peak, are unchanged.
///
/// ```
/// skylod::model::reserve_heap(1 << 20);
/// let v: Vec<u64> = (0..1000).collect();
/// assert_eq!(v.len(), 1000);
/// ```
pub fn reserve_heap(bytes: usize) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const BLOCK: usize = 120 << 10;
        let n = bytes.min(RESERVE_MAX_BYTES) / BLOCK;
        let mut held: Vec<*mut libc::c_void> = Vec::with_capacity(n);
        for _ in 0..n {
            // SAFETY: a plain allocation of BLOCK bytes, never read or written here; a null
            // (out of memory) ends the reservation.
            let p = unsafe { libc::malloc(BLOCK) };
            if p.is_null() {
                break;
            }
            held.push(p);
        }
        for p in held {
            // SAFETY: each pointer came from `malloc` above and is freed once.
            unsafe { libc::free(p) };
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    let _ = bytes;
}
