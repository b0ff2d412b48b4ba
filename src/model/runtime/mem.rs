//! Memory given back between stages.
//!
//! A stage frees what only it needed (the reader's id registry and polygon arena, the rough
//! stage's work buffers), but glibc's allocator keeps freed heap pages in the process: the
//! next stage's large blocks (a BVH's nodes, a writer's index) are separate mappings and do
//! not reuse them, so the process's peak would be every stage's garbage plus the next
//! stage's work. [`give_back`] returns the free pages to the system (glibc's `malloc_trim`);
//! elsewhere it does nothing.

/// Models of at least this many assets give their free pages back between stages
/// ([`give_back_for`]); below it the pages freed are few and the trim costs more than it
/// saves (the paper district, 57,530 assets: 40 ms of a 0.63 s `lod`; the 1 GB city, 463,370
/// assets: 47 MiB off its peak).
pub const GIVE_BACK_MIN_ASSETS: usize = 200_000;

static ENABLED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

/// Whether the pipeline gives pages back between stages ([`give_back_for`]); on by
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
/// skylod::model::runtime::mem::give_back();
/// ```
pub fn give_back() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory of the allocator's own arenas; it takes
    // the allocator's locks and has no precondition on the caller.
    unsafe {
        libc::malloc_trim(0);
    }
}
