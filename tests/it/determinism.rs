//! Contract: the thread count changes nothing — identical runs.parquet contents and
//! byte-identical reports for --threads 1 and --threads 2.

use crate::util::{run_and_report, tree};
use slamlab::store;

#[test]
fn one_and_two_threads_give_identical_results_and_reports() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    run_and_report("experiments/smoke.toml", a.path(), "1");
    run_and_report("experiments/smoke.toml", b.path(), "2");
    let runs_a = store::read_runs(&a.path().join("results/smoke")).unwrap();
    let runs_b = store::read_runs(&b.path().join("results/smoke")).unwrap();
    assert_eq!(runs_a, runs_b);
    let traces =
        |d: &std::path::Path| store::read_traces(&d.join("results/smoke"), &|_| true).unwrap();
    assert_eq!(traces(a.path()), traces(b.path()));
    let (ra, rb) = (tree(&a.path().join("reports")), tree(&b.path().join("reports")));
    assert_eq!(
        ra.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        rb.iter().map(|(n, _)| n).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in ra.iter().zip(&rb) {
        assert!(x == y, "{name} differs between 1 and 2 threads");
    }
}

/// Same spec, separate processes ⇒ the same results, for the NLopt optimiser whose C code reads
/// heap memory it has not written (TNEWTON). Before the fixed malloc fill (src/main.rs), four
/// processes running these 21 TNEWTON runs of `ep-simultaneous` gave three different results.
#[test]
fn tnewton_gives_the_same_results_in_every_process() {
    let spec =
        std::fs::read_to_string(crate::util::repo().join("experiments/ep-simultaneous.toml"))
            .unwrap();
    let spec = spec[..spec.find("[[claims]]").unwrap_or(spec.len())].replace("algorithms = [\"psm\", \"epsm\", \"direct_l\", \"crs2\", \"isres\", \"mlsl_lds\", \"cobyla\", \"bobyqa\", \"sbplx\", \"slsqp\", \"lbfgs\", \"tnewton\", \"var2\"]", "algorithms = [\"tnewton\"]");
    assert!(
        spec.contains("algorithms = [\"tnewton\"]"),
        "the spec's algorithm list changed: update this test"
    );
    let work = tempfile::tempdir().unwrap();
    std::fs::write(work.path().join("ep-simultaneous.toml"), spec).unwrap();
    let results: Vec<Vec<store::RunRow>> = (0..4)
        .map(|k| {
            let (r, c) = (work.path().join(format!("r{k}")), work.path().join(format!("c{k}")));
            let spec = work.path().join("ep-simultaneous.toml");
            crate::util::ok(&[
                "run",
                "-q",
                "-j",
                "2",
                spec.to_str().unwrap(),
                "--results",
                r.to_str().unwrap(),
                "--cache",
                c.to_str().unwrap(),
            ]);
            store::read_runs(&r.join("ep-simultaneous")).unwrap()
        })
        .collect();
    assert_eq!(results[0].len(), 21);
    for (k, r) in results.iter().enumerate().skip(1) {
        assert_eq!(&results[0], r, "process {k} differs from process 0");
    }
}
