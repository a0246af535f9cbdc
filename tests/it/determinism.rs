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

/// Same spec, separate processes, different heap contents ⇒ the same results, for the NLopt
/// optimiser whose C code once read memory it had not written (TNEWTON: `build/nlopt_patch.rs`).
/// Each process gets another glibc fill byte for freshly allocated memory (`MALLOC_PERTURB_`, none
/// for the first): with NLopt unpatched and no fill set by slamlab, these 21 TNEWTON runs of
/// `ep-simultaneous` differed between the processes. On other C libraries the variable is ignored
/// and the processes differ only in address-space layout.
#[test]
fn tnewton_gives_the_same_results_whatever_the_heap_held() {
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
    let fills = [None, Some("60"), Some("90"), Some("238")];
    let results: Vec<Vec<store::RunRow>> = fills
        .iter()
        .enumerate()
        .map(|(k, fill)| {
            let (r, c) = (work.path().join(format!("r{k}")), work.path().join(format!("c{k}")));
            let spec = work.path().join("ep-simultaneous.toml");
            let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_slamlab"));
            command.args(["run", "-q", "-j", "2"]).arg(&spec).arg("--results").arg(&r);
            command.arg("--cache").arg(&c).env_remove("MALLOC_PERTURB_");
            if let Some(byte) = fill {
                command.env("MALLOC_PERTURB_", byte);
            }
            let out = command.output().expect("slamlab runs");
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            store::read_runs(&r.join("ep-simultaneous")).unwrap()
        })
        .collect();
    assert_eq!(results[0].len(), 21);
    for (k, r) in results.iter().enumerate().skip(1) {
        let differing: Vec<&str> = (results[0].iter().zip(r))
            .filter(|(a, b)| a != b)
            .map(|(a, _)| a.run_id.as_str())
            .collect();
        assert!(
            differing.is_empty() && r.len() == results[0].len(),
            "with MALLOC_PERTURB_={:?} these runs differ from the process without it: {differing:?}",
            fills[k]
        );
    }
}
