//! A study's memory does not grow with its runs' results (issue 26, item 8). Each run's trace,
//! landmarks and matches go to the cache as the run ends and are read back a batch at a time when
//! the study is written; a study keeps only its plan and each run's status, metrics and timing.
//!
//! 600 dead-reckoning runs on Bigloop2: written the old way (every run's results held until the
//! study was written) they needed about 0.75 GB (1 000 such runs peaked at 1.24 GB, 4 000 at
//! 4.9 GB; the same 4 000 now peak at 0.15 GB). Under a 400 MB cap on the address space the study
//! completes, with every run in its results.

use crate::util::repo;
use std::process::Command;

/// The cap on the address space (`ulimit -v`), in MiB.
const CAP_MIB: u64 = 400;
const RUNS: usize = 600;

#[test]
fn a_study_whose_results_exceed_the_memory_cap_completes() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("capped.toml");
    std::fs::write(
        &spec,
        format!(
            "id = \"capped\"\ntitle = \"Memory cap\"\nseed = 3\nreplicates = {RUNS}\nmaps = [\"bigloop2\"]\nalgorithms = [\"odometry\"]\n"
        ),
    )
    .unwrap();
    let (results, cache) = (dir.path().join("results"), dir.path().join("cache"));
    // Fixed thread counts and malloc arenas: the cap is on reserved address space, which grows
    // with both (not with what this test is about).
    let out = Command::new("bash")
        .arg("-c")
        .arg(format!(
            "ulimit -v {} && exec \"$0\" run --quiet --threads 2 --results \"$1\" --cache \"$2\" \"$3\"",
            CAP_MIB * 1024
        ))
        .arg(env!("CARGO_BIN_EXE_slamlab"))
        .arg(&results)
        .arg(&cache)
        .arg(&spec)
        .env("MALLOC_ARENA_MAX", "2")
        .env("POLARS_MAX_THREADS", "2")
        .env("RAYON_NUM_THREADS", "2")
        .current_dir(repo())
        .output()
        .expect("bash runs");
    assert!(
        out.status.success(),
        "the study failed under a {CAP_MIB} MiB cap:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = slamlab::store::read_runs(&results.join("capped")).unwrap();
    assert_eq!(rows.len(), RUNS);
    assert!(rows.iter().all(|r| r.status == slamlab::store::RunStatus::Ok));
    // every run's trace is in the results: the results are larger than the cap allowed to hold
    let timings = slamlab::store::read_timings(&results.join("capped")).unwrap();
    let steps: u64 = timings.iter().map(|t| u64::from(t.steps) + 1).sum();
    assert!(timings.iter().all(|t| t.steps > 1000), "Bigloop2's runs are long");
    assert_eq!(timings.len(), RUNS);
    assert!(steps > 1_000_000, "{steps} trace rows");
}
