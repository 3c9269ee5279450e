//! The process's memory allocator, set for runs of many steps.
//!
//! A step of a large assembly builds and drops several buffers of a few hundred kB (the contact
//! rows of a 215-block wall: 1208 points of 240 bytes, for each problem of the step). glibc's
//! malloc serves blocks that large from fresh `mmap`s and gives freed memory at the top of its
//! heap back to the system, so that every step faults its pages in again. Whether a run falls
//! into that pattern depends on where the buffers land in the heap, i.e. on any change to what
//! a step allocates: measured on the 215-block wall under El Centro x2 (1000 steps, 1 s), a
//! build of the sparse back-end that kept two more row-length vectors took 85 000 page faults
//! and 0.83 ms a step (the build without them 3 745 faults), and with both thresholds raised
//! 900 faults and 0.69 ms a step. The command line and the benchmark drivers call
//! [`keep_freed_memory`] first; it changes when memory is returned, never a result.

/// Serve blocks up to 64 MiB from the heap and keep up to 256 MiB of freed memory at its top
/// (glibc on Linux; elsewhere nothing).
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets allocator parameters; both values are in range.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 64 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}
