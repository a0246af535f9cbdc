//! Contract: results assembled from shards (`run --shard I/N` for every I, then `run`) are
//! byte-identical to a single-process run, whatever N; every run is computed by exactly one
//! shard; and `plan --shards` shows the same partition.

use crate::util::{ok, s, slamlab, tree};
use std::path::Path;

/// …and a study with morris and sobol sweeps (design points are sweep points like any other).
const SPECS: [&str; 3] =
    ["experiments/smoke.toml", "experiments/odometry-rate.toml", "tests/specs/gsa.toml"];

/// Every file of the results except the machine-dependent timings (and their line in the
/// checksums), and every report file.
fn outputs(work: &Path) -> Vec<(String, Vec<u8>)> {
    let without_timings = |(name, bytes): (String, Vec<u8>)| {
        let bytes = if name.ends_with("checksums.b3") {
            String::from_utf8(bytes)
                .unwrap()
                .lines()
                .filter(|l| !l.contains("timings."))
                .collect::<Vec<_>>()
                .join("\n")
                .into_bytes()
        } else {
            bytes
        };
        (format!("results/{name}"), bytes)
    };
    let mut files: Vec<(String, Vec<u8>)> = tree(&work.join("results"))
        .into_iter()
        .filter(|(name, _)| !name.contains("timings."))
        .map(without_timings)
        .collect();
    files.extend(tree(&work.join("reports")).into_iter().map(|(n, b)| (format!("reports/{n}"), b)));
    files
}

/// The cache's entries (`<cache>/<first two hex digits>/<hash>/`).
fn entries(cache: &Path) -> Vec<std::path::PathBuf> {
    let visible = |e: &std::fs::DirEntry| !e.file_name().to_string_lossy().starts_with('.');
    let mut out: Vec<_> = std::fs::read_dir(cache)
        .unwrap()
        .flatten()
        .filter(visible)
        .flat_map(|d| {
            std::fs::read_dir(d.path()).unwrap().flatten().filter(visible).map(|e| e.path())
        })
        .collect();
    out.sort();
    out
}

fn finish(work: &Path) {
    let (results, cache, reports) =
        (work.join("results"), work.join("cache"), work.join("reports"));
    let mut args = vec!["run", "--quiet", "--results", s(&results), "--cache", s(&cache)];
    args.extend(SPECS);
    let out = ok(&args);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.lines().filter(|l| l.contains(" runs (")).all(|l| l.contains("(0 computed")),
        "the shards left runs to compute:\n{said}"
    );
    ok(&["report", "--results", s(&results), "--out", s(&reports)]);
}

#[test]
fn shards_assemble_to_the_single_process_results_whatever_n() {
    let single = tempfile::tempdir().unwrap();
    let (results, cache) = (single.path().join("results"), single.path().join("cache"));
    let mut args = vec!["run", "--quiet", "--results", s(&results), "--cache", s(&cache)];
    args.extend(SPECS);
    ok(&args);
    ok(&["report", "--results", s(&results), "--out", s(&single.path().join("reports"))]);
    let expected = outputs(single.path());
    assert!(expected.iter().any(|(n, _)| n.ends_with("runs.parquet")));

    for n in [1usize, 3, 7] {
        let work = tempfile::tempdir().unwrap();
        let (cache, results) = (work.path().join("cache"), work.path().join("results"));
        let mut computed = 0;
        for i in 1..=n {
            let shard = format!("{i}/{n}");
            let mut args = vec![
                "run",
                "--quiet",
                "--shard",
                &shard,
                "--cache",
                s(&cache),
                "--results",
                s(&results),
            ];
            args.extend(SPECS);
            let out = ok(&args);
            let said = String::from_utf8_lossy(&out.stderr);
            let line = said
                .lines()
                .find(|l| l.starts_with(&format!("shard {shard}:")))
                .unwrap_or_else(|| panic!("no summary from shard {shard}:\n{said}"));
            computed += line
                .split(" computed")
                .next()
                .and_then(|x| x.rsplit(' ').next())
                .and_then(|x| x.parse::<usize>().ok())
                .expect("a computed count");
            assert!(!work.path().join("results").exists(), "shard {shard} wrote study results");
        }
        let distinct = entries(&cache).len();
        assert_eq!(
            computed, distinct,
            "N = {n}: the shards computed {computed} runs for {distinct} cache entries (a run computed twice, or none)"
        );
        finish(work.path());
        let got = outputs(work.path());
        assert_eq!(
            got.iter().map(|(n, _)| n).collect::<Vec<_>>(),
            expected.iter().map(|(n, _)| n).collect::<Vec<_>>(),
            "N = {n}: other files"
        );
        for ((name, a), (_, b)) in got.iter().zip(&expected) {
            assert!(a == b, "N = {n}: {name} differs from the single-process run");
        }
    }
}

/// Runs shard `shard` of `spec` into `cache`: the runs it computed, from its summary line.
fn computed_by_shard(spec: &str, cache: &Path, shard: &str) -> usize {
    let out = ok(&["run", "--quiet", "--shard", shard, "--cache", s(cache), spec]);
    let said = String::from_utf8_lossy(&out.stderr);
    said.lines()
        .find(|l| l.starts_with(&format!("shard {shard}:")))
        .and_then(|l| l.split(" computed").next())
        .and_then(|x| x.rsplit(' ').next())
        .and_then(|x| x.parse::<usize>().ok())
        .unwrap_or_else(|| panic!("no summary from shard {shard}:\n{said}"))
}

/// Runs of one plan that share a content hash (a swept section one algorithm does not read)
/// are one run: a shard computes it once, and the shards together compute each entry once.
#[test]
fn a_shard_computes_a_run_shared_within_a_study_once() {
    const SPEC: &str = "tests/specs/shared-runs.toml";
    let work = tempfile::tempdir().unwrap();
    let cache = work.path().join("cache");
    let mut computed = 0;
    for shard in ["1/2", "2/2"] {
        computed += computed_by_shard(SPEC, &cache, shard);
    }
    let distinct = entries(&cache).len();
    // 2 points × 2 replicates of odometry_map, and 2 replicates of odometry shared by the points
    assert_eq!(distinct, 6, "the spec no longer shares runs between its points");
    assert_eq!(computed, distinct, "a run shared within the study was computed twice");
}

#[test]
fn a_shard_resumes_where_a_killed_one_stopped() {
    let work = tempfile::tempdir().unwrap();
    let cache = work.path().join("cache");
    let shard = |k: &str| {
        let out = ok(&["run", "--quiet", "--shard", k, "--cache", s(&cache), SPECS[1]]);
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let first = shard("1/2");
    assert!(!first.contains(" 0 computed"), "{first}");
    // as if the task had been killed after writing some entries: remove half of them
    let entries = entries(&cache);
    for e in entries.iter().step_by(2) {
        std::fs::remove_dir_all(e).unwrap();
    }
    let again = shard("1/2");
    let expect = format!("{} computed, {} cached", entries.len().div_ceil(2), entries.len() / 2);
    assert!(again.contains(&expect), "expected `{expect}`:\n{again}");
    assert!(shard("1/2").contains(&format!("0 computed, {} cached", entries.len())));
}

#[test]
fn plan_shows_each_runs_shard_and_the_cost_per_shard() {
    let work = tempfile::tempdir().unwrap();
    let out = ok(&[
        "plan",
        "--dry-run",
        "--shards",
        "3",
        SPECS[0],
        SPECS[1],
        "--cache",
        s(&work.path().join("cache")),
        "--results",
        s(&work.path().join("results")),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    let table: Vec<&str> = text.lines().skip_while(|l| !l.starts_with("shard ")).collect();
    assert!(table.len() >= 5, "{text}");
    let rows: Vec<Vec<&str>> = table[1..].iter().map(|l| l.split_whitespace().collect()).collect();
    assert_eq!(rows.iter().map(|r| r[0]).collect::<Vec<_>>(), ["1/3", "2/3", "3/3", "all"]);
    let runs: Vec<usize> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert_eq!(runs[0] + runs[1] + runs[2], runs[3]);
    let per_run = text.lines().filter(|l| l.starts_with("new ")).count();
    assert!(per_run >= runs[3], "every run is listed with its shard:\n{text}");
    // each shard's expected cost is within the LPT bound of the mean
    let cost: Vec<f64> = rows.iter().map(|r| r[3].parse().unwrap()).collect();
    assert!(cost[..3].iter().all(|&c| c > 0.0), "{text}");
    // a bad N is refused
    let bad = slamlab(&["plan", "--shards", "0", SPECS[0]]);
    assert!(!bad.status.success());
    let bad = slamlab(&["run", "--shard", "4/3", SPECS[0]]);
    assert_eq!(
        bad.status.code(),
        Some(2),
        "clap refuses a bad --shard: {}",
        String::from_utf8_lossy(&bad.stderr)
    );
    assert!(String::from_utf8_lossy(&bad.stderr).contains("I must be between 1 and N = 3"));
}

/// A sequential study (issue 31) takes the same stages, runs and verdicts whatever the thread
/// count or shard: its stages are a function of the runs' results. An array pass computes the
/// stage the cache stands at; passes repeat until one computes nothing, and `run` then finds
/// every run cached. A second `run` computes nothing (the stages are cached).
#[test]
fn a_sequential_study_takes_the_same_stages_whatever_the_threads_or_shards() {
    const SPEC: &str = "tests/specs/sequential.toml";
    let single = |threads: &str| {
        let work = tempfile::tempdir().unwrap();
        let (results, cache) = (work.path().join("results"), work.path().join("cache"));
        let args =
            ["run", "--quiet", "-j", threads, "--results", s(&results), "--cache", s(&cache), SPEC];
        ok(&args);
        let again = ok(&args);
        let said = String::from_utf8_lossy(&again.stderr);
        assert!(said.contains("(0 computed"), "a second run computed runs:\n{said}");
        ok(&["report", "--results", s(&results), "--out", s(&work.path().join("reports"))]);
        work
    };
    let one = single("1");
    let expected = outputs(one.path());
    let runs = expected.iter().find(|(n, _)| n.ends_with("runs.parquet")).unwrap();
    assert!(!runs.1.is_empty());
    let report = String::from_utf8(
        expected.iter().find(|(n, _)| n.ends_with("sequential/index.html")).unwrap().1.clone(),
    )
    .unwrap();
    assert!(report.contains("Sequential replication: the looks"), "no looks in the report");
    assert!(report.contains("published items staged"), "the staged item is not in the report");
    assert!(
        !report.contains("runs of the next stage are missing"),
        "the report's looks disagree with the stages `run` took"
    );
    assert_eq!(outputs(single("2").path()), expected, "the thread count changed the results");

    let work = tempfile::tempdir().unwrap();
    let (cache, results) = (work.path().join("cache"), work.path().join("results"));
    let mut passes = 0;
    loop {
        let mut computed = 0;
        for shard in ["1/2", "2/2"] {
            computed += computed_by_shard(SPEC, &cache, shard);
        }
        passes += 1;
        if computed == 0 {
            break;
        }
        assert!(passes < 10, "the array passes never settle");
    }
    assert!(passes > 2, "one pass per stage, and the stages were more than one");
    let out = ok(&["run", "--quiet", "--results", s(&results), "--cache", s(&cache), SPEC]);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("(0 computed"), "the shards left runs to compute:\n{said}");
    ok(&["report", "--results", s(&results), "--out", s(&work.path().join("reports"))]);
    assert_eq!(outputs(work.path()), expected, "the shards changed the results");
}
