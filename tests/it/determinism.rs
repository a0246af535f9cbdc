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
    let traces = |d: &std::path::Path| store::read_traces(&d.join("results/smoke"), &|_| true).unwrap();
    assert_eq!(traces(a.path()), traces(b.path()));
    let (ra, rb) = (tree(&a.path().join("reports")), tree(&b.path().join("reports")));
    assert_eq!(ra.iter().map(|(n, _)| n).collect::<Vec<_>>(), rb.iter().map(|(n, _)| n).collect::<Vec<_>>());
    for ((name, x), (_, y)) in ra.iter().zip(&rb) {
        assert!(x == y, "{name} differs between 1 and 2 threads");
    }
}
