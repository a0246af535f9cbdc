fn main() -> std::process::ExitCode {
    deterministic_heap();
    slamlab::cli::main()
}

/// Makes every block `malloc` returns start with the same bytes (glibc's `M_PERTURB`).
///
/// NLopt's TNEWTON (Lukšan's PNET, C code built by the `nlopt` crate) reads parts of its `malloc`ed
/// work arrays before writing them, so its result depended on what the heap held before: with
/// address-space randomisation, the same run gave different results from one process to the next
/// (1 of 21 TNEWTON runs of `ep-simultaneous` differed between two runs of the same spec; see
/// `tests/it/determinism.rs`). With a fixed fill byte that garbage is the same in every process.
/// NLopt's code is not ours to patch; this is the one process-wide setting that removes the
/// dependence. The cost is one `memset` per allocation (measured in the README, *Benchmarks*).
fn deterministic_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        unsafe extern "C" {
            fn mallopt(param: std::ffi::c_int, value: std::ffi::c_int) -> std::ffi::c_int;
        }
        /// glibc's `M_PERTURB` (malloc.h).
        const M_PERTURB: std::ffi::c_int = -6;
        // SAFETY: mallopt only sets glibc's fill byte; called once, before any thread starts.
        unsafe {
            mallopt(M_PERTURB, 0x5A);
        }
    }
}
