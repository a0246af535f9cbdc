//! The layering rule (CONVENTIONS.md §1): pure layers do no IO, printing, threading, Parquet or
//! global randomness; only store/ touches polars, only report/ plotters and minijinja, only run/
//! rayon.

use crate::util::repo;
use std::path::Path;

const PURE: &[&str] = &["geom", "world", "features", "slam", "scanmatch", "metrics"];
const FORBIDDEN_IN_PURE: &[&str] = &[
    "std::fs",
    "std::io",
    "std::net",
    "std::env",
    "std::thread",
    "std::process",
    "println!",
    "eprintln!",
    "print!(",
    "dbg!",
    "rayon",
    "polars",
    "plotters",
    "minijinja",
    "thread_rng",
    "rand::rng(",
    "from_entropy",
    "OsRng",
    "Instant::now",
    "SystemTime",
];

fn sources(dir: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(sources(&p));
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push((p.display().to_string(), std::fs::read_to_string(&p).unwrap()));
            }
        }
    }
    out
}

/// Source without comments (doc comments may mention anything).
fn code(text: &str) -> String {
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// Modules of `std` a pure layer must not import, also when grouped: `use std::{fs, io}`.
const FORBIDDEN_STD_MODULES: &[&str] = &["fs", "io", "net", "env", "thread", "process", "time"];

#[test]
fn pure_layers_stay_pure() {
    let src = repo().join("src");
    for layer in PURE {
        for (path, text) in sources(&src.join(layer)) {
            let code = code(&text);
            for bad in FORBIDDEN_IN_PURE.iter().chain(&["rand::random", "File::", "OpenOptions"]) {
                assert!(
                    !code.contains(bad),
                    "{path} uses `{bad}`: pure layers do no IO, threading or global randomness"
                );
            }
            // grouped imports: `use std::{fs, io::Write}`
            for group in code.split("std::{").skip(1) {
                let items = group.split('}').next().unwrap_or("");
                for item in
                    items.split(',').map(|i| i.trim().split("::").next().unwrap_or("").trim())
                {
                    assert!(
                        !FORBIDDEN_STD_MODULES.contains(&item),
                        "{path} imports std::{item}: pure layers do no IO, threading or timing"
                    );
                }
            }
        }
    }
}

#[test]
fn each_dependency_stays_in_its_layer() {
    let src = repo().join("src");
    let rules = [
        ("polars", "store"),
        ("plotters", "report"),
        ("minijinja", "report"),
        ("rayon", "run"),
        ("indicatif", "run"),
    ];
    for (path, text) in sources(&src) {
        // The one use of rayon outside run/: the store asserts that its Parquet IO is not on a
        // rayon worker (polars inside a worker nests jobs until the stack overflows).
        let code = code(&text).replace("rayon::current_thread_index()", "");
        for (dep, home) in rules {
            let inside = Path::new(&path).starts_with(src.join(home));
            assert!(
                inside || !code.contains(&format!("{dep}::")),
                "{path} uses {dep}, which belongs in src/{home}/ only"
            );
        }
    }
}

#[test]
fn every_source_file_says_what_it_does() {
    for (path, text) in sources(&repo().join("src")) {
        if path.ends_with("main.rs") {
            continue;
        }
        assert!(
            text.trim_start().starts_with("//!"),
            "{path} must start with a //! comment saying its role"
        );
    }
}

/// Verdicts live below the pages that show them: `stats/` and `judge/` import neither `report/`
/// nor `diff/`, `diff/` does not reach into `report/`, and `spec/` (the judge's input) imports none
/// of them.
#[test]
fn verdict_rules_sit_below_report_and_diff() {
    let src = repo().join("src");
    for (layer, banned) in [
        ("stats", &["crate::report", "crate::diff", "crate::judge"][..]),
        ("judge", &["crate::report", "crate::diff"][..]),
        ("diff", &["crate::report"][..]),
        // the specs are the judge's input, never the other way round
        ("spec", &["crate::judge", "crate::report", "crate::diff"][..]),
    ] {
        for (path, text) in sources(&src.join(layer)) {
            let code = code(&text);
            for b in banned {
                assert!(!code.contains(b), "{path} uses `{b}`: {layer}/ must not depend on it");
            }
        }
    }
}

/// The world is simulated without the filters: `world/` and `dataset/` (which build worlds)
/// import nothing from `slam/` (what kind of world a map makes, `WorldKind`, is the world's).
#[test]
fn worlds_do_not_depend_on_the_filters() {
    let src = repo().join("src");
    for layer in ["world", "dataset"] {
        for (path, text) in sources(&src.join(layer)) {
            assert!(
                !code(&text).contains("crate::slam"),
                "{path} uses crate::slam: the world must not depend on the filters"
            );
        }
    }
}
