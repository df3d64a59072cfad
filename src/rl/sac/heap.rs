//! The heap policy of a training process: freed memory kept for the next gradient step.
//!
//! Every SAC update builds and drops the same few hundred tensors, the largest 512 KiB
//! (a batch of 1024 through a 128-wide layer). glibc's `malloc` hands blocks that large
//! back to the kernel when they are freed, or trims them off the top of the heap, and
//! the next update faults the same pages in again, zeroed: on one core a third of an
//! update went to page faults (`docs/benchmarks.md`, "The SAC update against one core's
//! peak"). Raising the two thresholds keeps those blocks in the heap for reuse; the
//! process holds on to its peak heap instead of returning it, a few tens of MiB for a
//! training.

/// Blocks below this many bytes come from the heap, not from a mapping of their own
/// (glibc's own ceiling for the threshold it adapts by itself).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MAPPING_THRESHOLD: libc::c_int = 32 << 20;
/// Free memory at the top of the heap up to this many bytes is kept, not trimmed.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const TRIM_THRESHOLD: libc::c_int = 64 << 20;

/// Keeps freed memory in the heap for reuse (glibc; elsewhere the allocator's own policy
/// stays). Process-wide and idempotent; training calls it when it makes its device.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            // SAFETY: `mallopt` only sets two of the allocator's tuning parameters; it takes
            // the allocator's own lock, so it is safe beside other threads' allocations.
            // A refused value (it returns 0) leaves glibc's default: nothing to report.
            unsafe {
                libc::mallopt(libc::M_MMAP_THRESHOLD, MAPPING_THRESHOLD);
                libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
            }
        });
    }
}
