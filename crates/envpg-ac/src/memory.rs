//! Process-wide allocator setting for the learner's allocation pattern.
//!
//! Every learner iteration allocates and frees buffers of a few hundred kilobytes to a few
//! megabytes (network columns, activations, gemm packing). With glibc's defaults, freed
//! memory at the top of the heap above the (dynamic) trim threshold goes back to the kernel,
//! and the next iteration takes it again one zeroed page at a time: on the UAV instance this
//! costs a third of the run in page faults (a κ = 1 run: 20.3 s wall, 7.8 s of it system
//! time, against 13.0 s and 0.8 s with the setting below).

/// Keeps freed heap memory in the process instead of returning it to the kernel after every
/// learner iteration: fixes glibc's mmap threshold at 32 MiB (its maximum on 64-bit) and its
/// trim threshold at 256 MiB, so the buffers of one iteration are reused by the next.
///
/// Call it once at the start of a process that runs [`crate::Learner`]. It changes speed
/// only, never results. A no-op where the C library is not glibc.
pub fn retain_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const MMAP_THRESHOLD: libc::c_int = 32 << 20;
        const TRIM_THRESHOLD: libc::c_int = 256 << 20;
        // SAFETY: mallopt only sets allocator parameters; both values are in glibc's valid range
        // (a refusal returns 0 and leaves the defaults, which is harmless).
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
            libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
        }
    }
}
