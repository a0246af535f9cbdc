//! Contract: the smoke study runs end to end into a temporary directory; its Parquet, HTML, TeX
//! and CSV parse and agree with the plan; a second run is fully cached and changes no byte;
//! a failing run is recorded and does not stop the study.

use crate::util::{ok, repo, run_and_report, s, tree};
use slamlab::store::{self, RunStatus};
use std::path::Path;

fn check_html(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse_with_options(
        &text,
        roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() },
    )
    .unwrap_or_else(|e| panic!("{} is not well-formed: {e}", path.display()));
    // every local link resolves
    for a in doc.descendants().filter(|n| n.has_tag_name("a")) {
        let href = a.attribute("href").unwrap();
        assert!(
            path.parent().unwrap().join(href).exists(),
            "{}: broken link {href}",
            path.display()
        );
    }
    doc.descendants().filter(|n| n.tag_name().name() == "svg").count()
}

fn check_tex(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains("\\begin{document}") && text.trim_end().ends_with("\\end{document}"));
    let mut stack = Vec::new();
    for part in text.split("\\begin{").skip(1) {
        stack.push(part.split('}').next().unwrap().to_string());
    }
    let ends: Vec<String> =
        text.split("\\end{").skip(1).map(|p| p.split('}').next().unwrap().to_string()).collect();
    stack.sort();
    let mut ends_sorted = ends.clone();
    ends_sorted.sort();
    assert_eq!(stack, ends_sorted, "{}: unbalanced environments", path.display());
    let (open, close) = (
        text.matches('{').count() - text.matches("\\{").count(),
        text.matches('}').count() - text.matches("\\}").count(),
    );
    assert_eq!(open, close, "{}: unbalanced braces", path.display());
    for input in text.split("\\input{").skip(1) {
        let file = input.split('}').next().unwrap();
        let fig = path.parent().unwrap().join(file);
        assert!(fig.is_file(), "{}: missing {file}", path.display());
        let body = std::fs::read_to_string(&fig).unwrap();
        assert!(body.contains("\\begin{axis}") && body.trim_end().ends_with("\\end{tikzpicture}"));
    }
}

#[test]
fn smoke_study_end_to_end_then_fully_cached() {
    let work = tempfile::tempdir().unwrap();
    let results = work.path().join("results");
    run_and_report("experiments/smoke.toml", work.path(), "2");

    // runs.parquet: one row per planned run, sorted, all ok
    let study = store::read_study(&results.join("smoke")).unwrap();
    assert_eq!(study.runs.len(), 2 * 2 * 2);
    let ids: Vec<&str> = study.runs.iter().map(|r| r.run_id.as_str()).collect();
    let mut sorted = ids.clone();
    sorted.sort();
    assert_eq!(ids, sorted);
    for r in &study.runs {
        assert_eq!(r.status, RunStatus::Ok, "{}", r.run_id);
        let ate = r.metric("ate_rmse_m").unwrap();
        match r.param("odometry.k").and_then(|v| v.as_f64()) {
            // noise-free odometry reproduces the truth
            Some(0.0) => assert!(ate < 1e-9, "{}: {ate}", r.run_id),
            Some(_) => assert!(ate > 0.01, "{}: {ate}", r.run_id),
            None => panic!("odometry.k column missing"),
        }
        assert!(r.metric("path_length_m").unwrap() > 200.0);
    }
    assert_eq!(study.manifest.runs, 8);
    assert_eq!(study.resolved.points.len(), 2);
    let traces = store::read_traces(&results.join("smoke"), &|_| true).unwrap();
    assert_eq!(traces.len(), 8);
    assert!(traces.iter().all(|t| t.truth.len() == t.estimate.len() && t.truth.len() > 1000));

    // reports
    let reports = work.path().join("reports");
    check_html(&reports.join("index.html"));
    let svgs = check_html(&reports.join("smoke/index.html"));
    assert!(svgs >= 3 + 2, "error-vs-parameter plots and trajectory figures inline, found {svgs}");
    check_tex(&reports.join("smoke/smoke.tex"));
    let csv = std::fs::read_to_string(reports.join("smoke/summary.csv")).unwrap();
    // header + maps × algorithms × points × metrics
    assert_eq!(csv.lines().count(), 1 + 2 * 2 * 3);
    assert!(csv.lines().all(|l| !l.contains("NaN")));
    for (name, bytes) in tree(&reports) {
        let text = String::from_utf8(bytes).unwrap();
        assert!(!text.contains(s(work.path())), "{name} contains an absolute path");
        assert!(!text.contains(s(&repo())), "{name} contains an absolute path");
    }

    // second run: nothing to compute, the results are left untouched, reports identical
    let before = tree(&reports);
    let results_before = tree(&results);
    let inode = |p: &Path| std::os::unix::fs::MetadataExt::ino(&std::fs::metadata(p).unwrap());
    let page = reports.join("smoke/index.html");
    let page_inode = inode(&page);
    run_and_report("experiments/smoke.toml", work.path(), "2");
    // an unchanged file is linked from the previous report, not written again
    assert_eq!(inode(&page), page_inode, "an unchanged report file was rewritten");
    assert!(
        tree(&results) == results_before,
        "the second run rewrote results although nothing changed"
    );
    assert!(tree(&reports) == before, "reports changed although nothing did");

    // a study rebuilt from the cache alone (results deleted) has the same runs, all cached
    let runs_before = store::read_runs(&results.join("smoke")).unwrap();
    std::fs::remove_dir_all(results.join("smoke")).unwrap();
    run_and_report("experiments/smoke.toml", work.path(), "2");
    let timings = store::read_timings(&results.join("smoke")).unwrap();
    assert!(timings.iter().all(|t| t.cached), "the rebuilt study recomputed something");
    assert_eq!(store::read_runs(&results.join("smoke")).unwrap(), runs_before);
    assert!(tree(&reports) == before, "reports from cached runs differ");
}

#[test]
fn plan_dry_run_explains_what_will_run() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache) = (work.path().join("results"), work.path().join("cache"));
    let plan = |extra: &[&str]| {
        let mut args = vec![
            "plan",
            "experiments/smoke.toml",
            "--dry-run",
            "--results",
            s(&results),
            "--cache",
            s(&cache),
        ];
        args.extend(extra);
        String::from_utf8(ok(&args).stdout).unwrap()
    };
    assert!(plan(&[]).contains("to run: 8 (new 8,"));
    ok(&[
        "run",
        "experiments/smoke.toml",
        "--quiet",
        "--results",
        s(&results),
        "--cache",
        s(&cache),
    ]);
    let out = plan(&[]);
    assert!(out.contains("to run: 0") && out.contains("cached: 8"), "{out}");
    assert!(plan(&["--force"]).contains("forced 8"));
    let spec = work.path().join("smoke.toml");
    let plan_of = |text: String| {
        std::fs::write(&spec, text).unwrap();
        String::from_utf8(
            ok(&["plan", s(&spec), "--results", s(&results), "--cache", s(&cache)]).stdout,
        )
        .unwrap()
    };
    let smoke = std::fs::read_to_string("experiments/smoke.toml").unwrap();
    // a new sweep value: new run ids for k = 0.2, the k = 0 runs unchanged
    let out = plan_of(smoke.replace("[0.0, 0.1]", "[0.0, 0.2]"));
    assert!(out.contains("new 4,") && out.contains("cached: 4"), "{out}");
    // the same run ids with other inputs (the seed changes every world): parameters changed
    let out = plan_of(smoke.replace("seed = 1", "seed = 2"));
    assert!(
        out.contains("parameters changed 8,")
            && out.lines().filter(|l| l.starts_with("parameters changed ")).count() == 8,
        "{out}"
    );
    // nothing changed but the cache was emptied
    std::fs::remove_dir_all(&cache).unwrap();
    assert!(plan(&[]).contains("cache entry missing 8,"));
    // no temporary folder is left next to the results
    let leftovers: Vec<_> = std::fs::read_dir(&results)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn report_replaces_only_what_it_may() {
    let work = tempfile::tempdir().unwrap();
    let results = work.path().join("results");
    ok(&[
        "run",
        "experiments/smoke.toml",
        "--quiet",
        "--results",
        s(&results),
        "--cache",
        s(&work.path().join("cache")),
    ]);
    let refused = |args: &[&str], message: &str| {
        let r = crate::util::slamlab(args);
        assert!(!r.status.success(), "slamlab {} succeeded", args.join(" "));
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(err.contains(message), "{err}");
    };
    // a foreign folder is never wiped
    let thesis = work.path().join("thesis");
    std::fs::create_dir(&thesis).unwrap();
    std::fs::write(thesis.join("chapter1.tex"), "precious").unwrap();
    refused(&["report", "--results", s(&results), "--out", s(&thesis)], "refusing to replace it");
    assert_eq!(std::fs::read_to_string(thesis.join("chapter1.tex")).unwrap(), "precious");
    // an empty or previously generated folder is fine
    let out = work.path().join("reports");
    ok(&["report", "--results", s(&results), "--out", s(&out)]);
    ok(&["report", "--results", s(&results), "--out", s(&out)]);
    let before = crate::util::tree(&out);
    // a results root with no study (a typo) is an error, and the reports stay as they were
    refused(
        &["report", "--results", s(&work.path().join("resluts")), "--out", s(&out)],
        "no such folder",
    );
    assert_eq!(crate::util::tree(&out), before);
    // a study report these results would drop is kept unless --prune
    std::fs::create_dir(out.join("ghost")).unwrap();
    std::fs::write(out.join("ghost/entry.json"), "{}").unwrap();
    refused(
        &["report", "--results", s(&results), "--out", s(&out)],
        "would drop (no results and not kept)",
    );
    assert!(out.join("ghost/entry.json").is_file() && out.join("smoke/index.html").is_file());
    let before = crate::util::tree(&out);
    // a mistyped --results or --specs never prunes anything: usage errors (exit 2), nothing
    // removed (the review's N31, N32: every report was deleted)
    let specs = work.path().join("specs");
    std::fs::create_dir(&specs).unwrap();
    std::fs::copy("experiments/smoke.toml", specs.join("smoke.toml")).unwrap();
    let typo = work.path().join("resultz");
    for args in [
        vec!["report", "--results", s(&typo), "--out", s(&out), "--specs", s(&specs), "--prune"],
        vec!["report", "--results", s(&results), "--out", s(&out), "--specs", s(&typo), "--prune"],
        // a prune removes only reports whose spec was deleted: it needs the spec folder
        vec!["report", "--results", s(&results), "--out", s(&out), "--prune"],
    ] {
        let r = crate::util::slamlab(&args);
        assert_eq!(r.status.code(), Some(2), "{}", String::from_utf8_lossy(&r.stderr));
        assert_eq!(
            crate::util::tree(&out),
            before,
            "slamlab {} changed the reports",
            args.join(" ")
        );
    }
    // with the spec folder, it prunes exactly the reports whose spec is gone, and names them
    let r = ok(&[
        "report",
        "--results",
        s(&results),
        "--out",
        s(&out),
        "--specs",
        s(&specs),
        "--prune",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("pruned ghost"), "{err}");
    assert!(!out.join("ghost").exists() && out.join("smoke/index.html").is_file());
}

#[test]
fn a_failing_run_is_recorded_and_the_study_goes_on() {
    let work = tempfile::tempdir().unwrap();
    let maps = work.path().join("maps");
    std::fs::create_dir(&maps).unwrap();
    std::fs::copy("data/maps/recinto_basico.toml", maps.join("recinto_basico.toml")).unwrap();
    // a waypoint behind the robot and an almost zero turn rate: the controller cannot get there
    std::fs::write(
        maps.join("stuck.toml"),
        "name = \"stuck\"\ntitle = \"Stuck\"\nstart = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }\n[[walls]]\npoints = [[-9, -9], [9, -9], [9, 9], [-9, 9], [-9, -9]]\n[trajectory]\nmax_speed_mps = 0.5\nmax_turn_rate_dps = 0.0001\nlaps = 1\nwaypoints = [[-5, 0]]\n",
    )
    .unwrap();
    let spec = work.path().join("failing.toml");
    std::fs::write(&spec, "id = \"failing\"\ntitle = \"Failing\"\nseed = 3\nreplicates = 2\nmaps = [\"stuck\", \"recinto_basico\"]\nalgorithms = [\"odometry\"]\n").unwrap();
    let (results, cache, reports) =
        (work.path().join("results"), work.path().join("cache"), work.path().join("reports"));
    let out = ok(&[
        "run",
        s(&spec),
        "--quiet",
        "--maps",
        s(&maps),
        "--results",
        s(&results),
        "--cache",
        s(&cache),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("2 failed"));
    let runs = store::read_runs(&results.join("failing")).unwrap();
    let stuck: Vec<_> = runs.iter().filter(|r| r.map == "stuck").collect();
    assert_eq!(stuck.len(), 2);
    assert!(stuck.iter().all(|r| r.status == RunStatus::Failed
        && r.error.as_deref().unwrap().contains("did not reach waypoint")));
    assert!(runs.iter().filter(|r| r.map == "recinto_basico").all(|r| r.status == RunStatus::Ok));
    ok(&["report", "--results", s(&results), "--out", s(&reports)]);
    let html = std::fs::read_to_string(reports.join("failing/index.html")).unwrap();
    assert!(html.contains("Failed runs") && html.contains("2/2"), "failures are shown as k/n");
    // the spec lies outside the repository: only its file name is recorded, no absolute path
    assert_eq!(
        store::read_study(&results.join("failing")).unwrap().manifest.spec_path,
        "failing.toml"
    );
    for (name, bytes) in tree(&reports) {
        assert!(
            !String::from_utf8_lossy(&bytes).contains(s(work.path())),
            "{name} contains an absolute path"
        );
    }
}

/// Contract: stored numbers are intact or refused. A flipped byte in a study's results makes
/// `report` and `diff` fail naming the file (and `run` rewrites the study); one in a cache entry
/// is found when the entry is read, and that run is recomputed, counted and reported, with the
/// same results as before.
#[test]
fn a_flipped_byte_in_stored_results_is_refused_or_recomputed() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache, reports) =
        (work.path().join("results"), work.path().join("cache"), work.path().join("reports"));
    let run = || {
        ok(&[
            "run",
            "experiments/smoke.toml",
            "--quiet",
            "--results",
            s(&results),
            "--cache",
            s(&cache),
        ])
    };
    run();
    let runs = results.join("smoke/runs.parquet");
    let good = std::fs::read(&runs).unwrap();
    let flip = |path: &Path| {
        let mut bytes = std::fs::read(path).unwrap();
        let k = bytes.len() / 2;
        bytes[k] ^= 0x10;
        std::fs::write(path, bytes).unwrap();
    };
    // the study's results: refused by report and diff, naming the file
    flip(&runs);
    for args in [
        vec!["report", "--results", s(&results), "--out", s(&reports)],
        vec!["diff", s(&results), s(&results)],
    ] {
        let r = crate::util::slamlab(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success()
                && err.contains("runs.parquet")
                && err.contains("does not match its checksum"),
            "{}: {err}",
            args[0]
        );
    }
    assert!(!reports.exists(), "nothing written");
    // `run` finds the study not up to date and rewrites it from the cache
    run();
    assert_eq!(std::fs::read(&runs).unwrap(), good);
    // a cache entry: recomputed on its next read, counted, and the same results
    let entry = walk_files(&cache)
        .into_iter()
        .find(|p| p.ends_with("trace.parquet"))
        .expect("a cached trace");
    flip(&entry);
    std::fs::remove_dir_all(&results).unwrap();
    let out =
        ok(&["run", "experiments/smoke.toml", "--results", s(&results), "--cache", s(&cache)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("failed verification") && err.contains("1 cache entries failed verification"),
        "{err}"
    );
    assert_eq!(std::fs::read(&runs).unwrap(), good, "recomputed to the same results");
    ok(&["report", "--results", s(&results), "--out", s(&reports)]);
}

fn walk_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk_files(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}
