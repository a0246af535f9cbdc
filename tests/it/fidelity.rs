//! Contract: the fidelity scoreboard's inputs are consistent with the studies, and the README
//! quotes the committed scoreboard verbatim (a stale block fails).

use crate::util::repo;
use slamlab::judge::scoreboard::parse_items;
use slamlab::spec;
use std::process::Command;

/// Tolerances come from the per-work table (`judge::margins`), not from the cells they judge:
/// every seed claim with a relative tolerance uses its work's margin, or its `why` says why it
/// deviates.
#[test]
fn relative_tolerances_are_the_works_margins() {
    let mut checked = 0;
    for entry in std::fs::read_dir(repo().join("experiments")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        let loaded = spec::load(&path, &crate::util::catalogue()).unwrap();
        for c in &loaded.spec.claims {
            let (Some(rel), Some(work)) = (c.tolerance_rel, slamlab::judge::margins::of(&c.source))
            else {
                continue;
            };
            checked += 1;
            assert!(
                (rel - work.relative).abs() < 1e-12 || c.why.contains("deviat"),
                "{}: claim {} has tolerance_rel {rel}, [{}]'s margin is {} ({})",
                path.display(),
                c.id,
                work.tag,
                work.relative,
                work.why
            );
        }
    }
    assert!(checked >= 5, "only {checked} relative tolerances found");
}

#[test]
fn published_items_name_existing_studies_and_claims() {
    let text =
        std::fs::read_to_string(repo().join("data/reference/published-results.toml")).unwrap();
    let items = parse_items(&text).unwrap_or_else(|e| panic!("published-results.toml: {e}"));
    assert_eq!(items.len(), 70, "the audit's inventory has 70 published result items");
    for seed in ["FT", "EP", "PF", "EV"] {
        assert!(items.iter().any(|i| i.seed == seed), "no item of [{seed}]");
    }
    for it in &items {
        let Some(study) = &it.study else { continue };
        let path = repo().join(format!("experiments/{study}.toml"));
        let loaded = spec::load(&path, &crate::util::catalogue())
            .unwrap_or_else(|e| panic!("{}: study {study}: {e}", it.id));
        for c in it.claims.iter().chain(&it.shape) {
            let claim = loaded.spec.claims.iter().find(|x| &x.id == c);
            assert!(claim.is_some(), "{}: claim {c} is not in {study}", it.id);
            assert!(
                claim.is_some_and(|x| x.judged_on.is_none()),
                "{}: claim {c} is judged on the timing page, never on the committed scoreboard",
                it.id
            );
        }
        if let Some(sel) = &it.cells {
            let reference = loaded
                .spec
                .report
                .reference
                .as_ref()
                .unwrap_or_else(|| panic!("{}: {study} shows no published values", it.id));
            assert!(
                reference.file.ends_with(&sel.file),
                "{}: {study} shows {}, the item selects {}",
                it.id,
                reference.file,
                sel.file
            );
        }
    }
}

fn block_check(readme: &std::path::Path, block: &std::path::Path) -> std::process::Output {
    Command::new("bash")
        .arg(repo().join("tests/tools/readme_block.sh"))
        .arg("check")
        .arg(readme)
        .arg(block)
        .output()
        .unwrap()
}

#[test]
fn readme_quotes_the_committed_scoreboard() {
    let out = block_check(&repo().join("README.md"), &repo().join("reports/fidelity/summary.md"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn a_stale_readme_block_fails_the_check() {
    let dir = tempfile::tempdir().unwrap();
    let readme = dir.path().join("README.md");
    let block = dir.path().join("summary.md");
    std::fs::write(&block, "| [FT] | 5 | 11 | 4 | 8 | 28 |\n").unwrap();
    std::fs::write(&readme, "# x\n<!-- fidelity:begin (generated) -->\n| [FT] | 6 | 10 | 4 | 8 | 28 |\n<!-- fidelity:end -->\n").unwrap();
    let out = block_check(&readme, &block);
    assert_eq!(
        out.status.code(),
        Some(1),
        "a stale block must fail: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("README.md"));
    // and writing it makes it pass
    let w = Command::new("bash")
        .arg(repo().join("tests/tools/readme_block.sh"))
        .arg("write")
        .arg(&readme)
        .arg(&block)
        .output()
        .unwrap();
    assert!(w.status.success());
    assert!(block_check(&readme, &block).status.success());
}

/// The Quick start runs one study and renders with `--specs experiments`: every other study keeps
/// its committed report, and with it its share of the scoreboard — its claims and its items
/// judged on published cells. The committed scoreboard and index must come out unchanged.
#[test]
fn rendering_one_study_keeps_the_committed_scoreboard() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache, reports) =
        (work.path().join("results"), work.path().join("cache"), work.path().join("reports"));
    let copy = std::process::Command::new("cp")
        .arg("-r")
        .arg(repo().join("reports"))
        .arg(&reports)
        .status()
        .unwrap();
    assert!(copy.success());
    crate::util::ok(&[
        "run",
        "experiments/smoke.toml",
        "--quiet",
        "--results",
        crate::util::s(&results),
        "--cache",
        crate::util::s(&cache),
    ]);
    let out = crate::util::ok(&[
        "report",
        "--results",
        crate::util::s(&results),
        "--out",
        crate::util::s(&reports),
        "--specs",
        "experiments",
    ]);
    // the kept reports are told in one line, not one each (the review's 42 lines)
    let said = String::from_utf8_lossy(&out.stderr);
    assert_eq!(said.lines().filter(|l| l.contains("no results here")).count(), 1, "{said}");
    for file in ["fidelity/summary.md", "fidelity/fidelity.md", "fidelity/index.html", "index.html"]
    {
        let committed = std::fs::read_to_string(repo().join("reports").join(file)).unwrap();
        let rendered = std::fs::read_to_string(reports.join(file)).unwrap();
        assert!(committed == rendered, "{file} changed when only smoke was rendered");
    }
}

/// Every inconclusive claim in the committed reports says how many replicates would decide it at
/// its observed means and spreads — or why replicates would not (a pooled claim needs maps, an
/// index claim design rows) — and every inconclusive map of it says its own count.
#[test]
fn every_inconclusive_claim_states_the_replicates_that_would_decide_it() {
    let mut checked = 0;
    for entry in std::fs::read_dir(repo().join("reports")).unwrap().flatten() {
        let path = entry.path().join("claims.json");
        let Ok(text) = std::fs::read_to_string(&path) else { continue };
        let claims: Vec<serde_json::Value> = serde_json::from_str(&text).unwrap();
        for c in claims.iter().filter(|c| c["verdict"] == "inconclusive") {
            let summary = c["summary"].as_str().unwrap();
            let said = [
                "Projected at each",
                "Pooled over the",
                "narrows with more design rows",
                "More replicates cannot decide it",
            ];
            assert!(said.iter().any(|s| summary.contains(s)), "{}: {summary}", path.display());
            if summary.contains("Projected at each") {
                for e in c["evidence"].as_array().unwrap().iter().filter_map(|e| e.as_str()) {
                    if e.contains(": inconclusive — ") {
                        assert!(e.contains("replicates would"), "{}: {e}", path.display());
                    }
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} inconclusive claims found");
}

/// Every UNRESOLVED item of the committed scoreboard says what would resolve it: its cells'
/// replicates (or that no count of ours can), or its inconclusive claims' projections.
#[test]
fn every_unresolved_item_states_what_would_resolve_it() {
    let board = std::fs::read_to_string(repo().join("reports/fidelity/fidelity.md")).unwrap();
    let rows: Vec<&str> = board
        .lines()
        .filter(|l| l.contains(" | UNRESOLVED | ") && !l.starts_with("| Reference work"))
        .collect();
    assert!(!rows.is_empty(), "the scoreboard has unresolved items");
    let said = [
        "would resolve at",
        "cannot be resolved by more runs",
        "projected at each",
        "pooled over the",
        "more replicates cannot",
        "narrows with more design rows",
    ];
    for row in rows {
        let lower = row.to_lowercase();
        assert!(said.iter().any(|s| lower.contains(s)), "{row}");
    }
}
