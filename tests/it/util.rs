//! Running the real binary in temporary directories.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn slamlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slamlab"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("slamlab runs")
}

/// Runs slamlab with arguments that need not be UTF-8.
pub fn slamlab_os(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slamlab"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("slamlab runs")
}

/// Runs slamlab and fails the test with its stderr if it does not succeed.
pub fn ok(args: &[&str]) -> Output {
    let out = slamlab(args);
    assert!(
        out.status.success(),
        "slamlab {} failed:\n{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Every file under `dir`, relative path → bytes, sorted.
pub fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.push((
                    p.strip_prefix(root).unwrap().to_string_lossy().into_owned(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Runs `spec` into `results`/`cache` and renders reports into `reports`.
pub fn run_and_report(spec: &str, work: &Path, threads: &str) {
    let (results, cache, reports) =
        (work.join("results"), work.join("cache"), work.join("reports"));
    ok(&[
        "run",
        spec,
        "--quiet",
        "--threads",
        threads,
        "--results",
        s(&results),
        "--cache",
        s(&cache),
    ]);
    ok(&["report", "--results", s(&results), "--out", s(&reports)]);
}

/// The algorithms the committed studies may name: the built-ins and `data/algorithms/`.
pub fn catalogue() -> std::sync::Arc<slamlab::algo::Catalogue> {
    slamlab::spec::algorithms::catalogue(&[repo().join("data/algorithms")])
        .unwrap_or_else(|e| panic!("data/algorithms: {e}"))
}
