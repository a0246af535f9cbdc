//! Contract: an algorithm in another language, declared by a descriptor and run through the file
//! protocol (docs/src/guide/external-algorithms.md), goes through the same pipeline as the built-ins — run,
//! cached, stored, reported — and a program that crashes, hangs, writes garbage or cannot start
//! is a failed run naming the cause, while the rest of the study goes on.
//!
//! Needs python3 with numpy (`tests/tools/python_deps.sh`, run by `make test`, installs them).

use crate::util::{ok, s, slamlab};
use slamlab::stats::compare::t_interval;
use slamlab::store::{self, RunRow, RunStatus};
use std::collections::BTreeMap;

const ALGORITHM_DIRS: [&str; 4] =
    ["--algorithms", "data/algorithms", "--algorithms", "tests/external/algorithms"];

/// `metric` of every replicate of `algorithm`.
fn by_replicate(runs: &[RunRow], algorithm: &str, metric: &str) -> BTreeMap<u32, f64> {
    runs.iter()
        .filter(|r| r.algorithm == algorithm && r.status == RunStatus::Ok)
        .filter_map(|r| r.metric(metric).map(|v| (r.replicate, v)))
        .collect()
}

fn error_of<'a>(runs: &'a [RunRow], algorithm: &str) -> Vec<&'a str> {
    runs.iter()
        .filter(|r| r.algorithm == algorithm)
        .map(|r| {
            assert_eq!(r.status, RunStatus::Failed, "{} should have failed", r.run_id);
            r.error.as_deref().unwrap_or("")
        })
        .collect()
}

#[test]
fn python_programs_run_beside_the_built_ins_and_their_failures_are_runs() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache, reports) =
        (work.path().join("results"), work.path().join("cache"), work.path().join("reports"));
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "tests/specs/external.toml", "--quiet", "--results"];
        args.extend([s(&results), "--cache", s(&cache)]);
        args.extend(ALGORITHM_DIRS);
        args.extend(extra);
        ok(&args)
    };
    run(&["--threads", "2"]);
    let study = store::read_study(&results.join("external")).unwrap();
    let runs = &study.runs;
    assert_eq!(runs.len(), 8 * 6);

    // Dead reckoning in Python reproduces the built-in to the TUM file's precision (1e-9 m).
    let (ours, theirs) = (
        by_replicate(runs, "odometry", "ate_rmse_m"),
        by_replicate(runs, "odometry_py", "ate_rmse_m"),
    );
    assert_eq!(theirs.len(), 6, "every Python dead-reckoning run succeeds");
    for (r, a) in &ours {
        assert!(
            (a - theirs[r]).abs() < 1e-6,
            "replicate {r}: odometry {a} vs Python {}",
            theirs[r]
        );
    }

    // The Python EKF-SLAM agrees with the built-in within statistical noise: the 95 % interval of
    // the paired mean difference lies within ±10 % of the built-in's mean (an equivalence test;
    // margin chosen before either was run), for the trajectory and the map error.
    for metric in ["ate_rmse_m", "map_rmse_m"] {
        let (builtin, python) =
            (by_replicate(runs, "ekf_slam", metric), by_replicate(runs, "ekf_slam_py", metric));
        assert_eq!(python.len(), 6, "every Python EKF run succeeds and reports {metric}");
        let d: Vec<f64> = builtin.iter().map(|(r, b)| python[r] - b).collect();
        let mean = builtin.values().sum::<f64>() / builtin.len() as f64;
        let (lo, hi) = t_interval(&d, 0.95);
        let margin = 0.1 * mean;
        assert!(
            -margin < lo && hi < margin,
            "{metric}: Python − built-in in [{lo}, {hi}], margin ±{margin}"
        );
        // and both are SLAM, not dead reckoning
        let dead = by_replicate(runs, "odometry", "ate_rmse_m");
        if metric == "ate_rmse_m" {
            assert!(python.iter().all(|(r, v)| *v < dead[r]), "{python:?} vs {dead:?}");
        }
    }

    // Failures: each a failed run with its cause, none stopping the study.
    for e in error_of(runs, "crash_py") {
        assert!(e.contains("exited with status 1") && e.contains("ZeroDivisionError"), "{e}");
        assert!(e.contains("reading the inputs"), "the tail of stderr is quoted: {e}");
    }
    for e in error_of(runs, "hang_py") {
        assert!(e.contains("did not finish within its timeout of 2 s"), "{e}");
    }
    for e in error_of(runs, "garbage_py") {
        assert!(e.contains("estimate.tum line 2") && e.contains("expected 8 numbers"), "{e}");
    }
    for e in error_of(runs, "missing_program") {
        assert!(e.contains("cannot start `slamlab-no-such-program`"), "{e}");
    }
    // the hung program's child was killed with it
    let ps = std::process::Command::new("ps").args(["-eo", "args"]).output().unwrap();
    assert!(
        !String::from_utf8_lossy(&ps.stdout).contains("time.sleep(120)"),
        "a hung program's children outlive the run"
    );

    // The external algorithms are recorded, and the report shows them.
    assert_eq!(
        study.resolved.externals.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(),
        ["ekf_slam_py", "crash_py", "garbage_py", "hang_py", "missing_program", "odometry_py"]
    );
    ok(&["report", "--results", s(&results), "--out", s(&reports)]);
    let html = std::fs::read_to_string(reports.join("external/index.html")).unwrap();
    assert!(
        html.contains("EKF-SLAM (Python)") && html.contains("external program"),
        "report names it"
    );

    // A second run takes every run from the cache (one thread: the same results).
    let before = std::fs::read(results.join("external/runs.parquet")).unwrap();
    run(&["--threads", "1"]);
    let plan = ok(&[
        "plan",
        "tests/specs/external.toml",
        "--results",
        s(&results),
        "--cache",
        s(&cache),
        ALGORITHM_DIRS[0],
        ALGORITHM_DIRS[1],
        ALGORITHM_DIRS[2],
        ALGORITHM_DIRS[3],
    ]);
    let text = String::from_utf8_lossy(&plan.stdout);
    assert!(text.contains("to run: 0 "), "nothing left to run:\n{text}");
    assert_eq!(before, std::fs::read(results.join("external/runs.parquet")).unwrap());
}

#[test]
fn a_wrong_descriptor_is_an_input_error_naming_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("mine.toml"),
        "title = \"Mine\"\nversion = \"1\"\ncommand = [\"python3\", \"x.py\"]\nreads = [\"sonar\"]\ndescription = \"d\"\n",
    )
    .unwrap();
    let out = slamlab(&["validate", "experiments/smoke.toml", "--algorithms", s(dir.path())]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("mine.toml") && err.contains(":4:") && err.contains("sonar"), "{err}");
}

#[test]
fn an_unknown_algorithm_names_the_external_folder() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("t.toml");
    std::fs::write(
        &spec,
        "id = \"t\"\ntitle = \"T\"\nseed = 1\nreplicates = 1\nmaps = [\"scatter\"]\nalgorithms = [\"odometry\", \"my_slam\"]\n",
    )
    .unwrap();
    let out = slamlab(&["validate", s(&spec)]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("unknown algorithm `my_slam`") && err.contains("data/algorithms"),
        "{err}"
    );
}

/// A scan matcher in Python gets the pairs slamlab's trigger chose and returns one estimate per
/// pair, which slamlab chains and scores like its own matchers': answering every pair with its
/// initial guess must reproduce dead reckoning along the matched steps, on PSM's pairs.
#[test]
fn an_external_scan_matcher_gets_the_pairs_and_is_chained() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache) = (work.path().join("results"), work.path().join("cache"));
    let mut args = vec!["run", "tests/specs/external-matcher.toml", "--quiet", "--results"];
    args.extend([s(&results), "--cache", s(&cache)]);
    args.extend(ALGORITHM_DIRS);
    ok(&args);
    let dir = results.join("external-matcher");
    let study = store::read_study(&dir).unwrap();
    assert!(study.runs.iter().all(|r| r.status == RunStatus::Ok), "{:?}", study.runs);
    let matches = store::read_matches(&dir, &|_| true).unwrap();
    let traces = store::read_traces(&dir, &|_| true).unwrap();
    let of = |algorithm: &str, replicate: u32| {
        let id = &study
            .runs
            .iter()
            .find(|r| r.algorithm == algorithm && r.replicate == replicate)
            .unwrap()
            .run_id;
        (matches.iter().find(|m| &m.run_id == id), traces.iter().find(|t| &t.run_id == id).unwrap())
    };
    for replicate in 0..2 {
        let ((echo, echo_trace), (psm, _), (_, odometry)) =
            (of("echo_matcher_py", replicate), of("psm", replicate), of("odometry", replicate));
        let (echo, psm) = (echo.expect("the external matcher's matches"), psm.expect("PSM's"));
        let pairs = |m: &store::MatchRows| {
            m.matches.iter().map(|k| (k.reference_step, k.current_step)).collect::<Vec<_>>()
        };
        assert_eq!(echo.matches.len(), 15, "max_matches = 15");
        assert_eq!(pairs(echo), pairs(psm), "every matcher of a study matches the same pairs");
        for m in &echo.matches {
            // the initial guess went out and came back bit for bit
            assert_eq!(m.estimate, m.initial);
            assert_eq!(m.stop, "external");
        }
        // every estimate is scored like a built-in matcher's: by the common objective f, and by
        // its error against the true pose change
        let row = study
            .runs
            .iter()
            .find(|r| r.algorithm == "echo_matcher_py" && r.replicate == replicate)
            .unwrap();
        assert_eq!(row.metric("match_failure_rate"), Some(0.0), "no match of the echo failed");
        assert!(row.metric("f_mean").is_some_and(f64::is_finite), "f of its estimates");
        assert!(row.metric("evals_mean").is_none_or(f64::is_nan), "it reports no evaluations");
        let atheta = echo
            .matches
            .iter()
            .map(|m| slamlab::geom::wrap_angle(m.initial.theta - m.truth.theta).abs().to_degrees())
            .sum::<f64>()
            / echo.matches.len() as f64;
        let got = row.metric("atheta_mean_deg").unwrap();
        assert!((got - atheta).abs() < 1e-9, "aθ of the echo {got} = that of the guesses {atheta}");
        // chained initial guesses are dead reckoning, up to the last match
        let last = echo.matches.last().unwrap().current_step;
        assert_eq!(echo_trace.estimate.len(), last + 1);
        for (k, (a, b)) in echo_trace.estimate.iter().zip(&odometry.estimate).enumerate() {
            assert!(
                (a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9,
                "step {k}: {a:?} vs dead reckoning {b:?}"
            );
        }
    }
}

#[test]
fn an_external_filter_on_a_world_without_its_sensor_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("t.toml");
    std::fs::write(
        &spec,
        "id = \"t\"\ntitle = \"T\"\nseed = 1\nreplicates = 1\nmaps = [\"bigloop2\"]\nalgorithms = [\"ekf_slam_py\"]\n",
    )
    .unwrap();
    let out = slamlab(&["validate", s(&spec)]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(":6:") && err.contains("laser world") && err.contains("bigloop2"),
        "{err}"
    );
}
