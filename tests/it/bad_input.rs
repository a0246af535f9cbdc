//! Contract: bad input is rejected with file, line and key, a non-zero exit, and nothing written.

use crate::util::{repo, s, slamlab};

const GOOD: &str = r#"id = "bad"
title = "Bad input"
seed = 1
replicates = 1
maps = ["recinto_basico"]
algorithms = ["odometry"]

[base.odometry]
model = "pose"
var_x_m2 = 0.001
var_y_m2 = 0.001
var_theta_rad2 = 0.0001
"#;

/// Writes `text` as a spec, runs it, and returns stderr after checking the exit status and that
/// no results, cache or report directory appeared.
fn rejected(text: &str) -> String {
    let work = tempfile::tempdir().unwrap();
    let spec = work.path().join("bad.toml");
    std::fs::write(&spec, text).unwrap();
    let (results, cache) = (work.path().join("results"), work.path().join("cache"));
    let out =
        slamlab(&["run", s(&spec), "--quiet", "--results", s(&results), "--cache", s(&cache)]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!results.exists() && !cache.exists(), "something was written");
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains(&format!("{}:", spec.display())), "stderr names the file: {stderr}");
    stderr
}

#[test]
fn the_good_spec_is_accepted() {
    let work = tempfile::tempdir().unwrap();
    let spec = work.path().join("bad.toml"); // named after its id
    std::fs::write(&spec, GOOD).unwrap();
    let out = slamlab(&["validate", s(&spec)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn unknown_key() {
    let err = rejected(&GOOD.replace("var_x_m2 = 0.001", "var_x_m2 = 0.001\nvar_z_m2 = 0.001"));
    assert!(
        err.contains("bad.toml:11:1: key `base.odometry.var_z_m2`: unknown field `var_z_m2`"),
        "{err}"
    );
}

#[test]
fn negative_variance() {
    let err = rejected(&GOOD.replace("var_theta_rad2 = 0.0001", "var_theta_rad2 = -0.0001"));
    assert!(
        err.contains("bad.toml:12:1: key `base.odometry.var_theta_rad2`: must be ≥ 0, got -0.0001"),
        "{err}"
    );
}

#[test]
fn negative_variance_in_a_sweep_points_at_the_value() {
    let err = rejected(&format!(
        "{GOOD}\n[[sweeps]]\nkind = \"one_at_a_time\"\nvalues = {{ \"odometry.var_x_m2\" = [0.001, -1.0] }}\n"
    ));
    assert!(
        err.contains("bad.toml:16:42: key `sweeps[0].values.\"odometry.var_x_m2\"[1]`"),
        "{err}"
    );
}

#[test]
fn missing_map() {
    let err = rejected(&GOOD.replace("[\"recinto_basico\"]", "[\"recinto_basico\", \"atlantis\"]"));
    assert!(
        err.contains("bad.toml:5:") && err.contains("key `maps[1]`: no map `atlantis`"),
        "{err}"
    );
    assert!(
        err.contains("available in data/maps: bigloop, bigloop2, complex, corridor_1m"),
        "{err}"
    );
}

#[test]
fn zero_particles_style_range_check_on_replicates() {
    let err = rejected(&GOOD.replace("replicates = 1", "replicates = 0"));
    assert!(err.contains("bad.toml:4:1: key `replicates`: must be ≥ 1"), "{err}");
}

#[test]
fn toml_syntax_error() {
    let err = rejected(&GOOD.replace("seed = 1", "seed = = 1"));
    assert!(err.contains("bad.toml:3:"), "{err}");
}

#[test]
fn a_published_landmark_table_must_name_a_sweep_point() {
    // it used to be skipped silently by the report
    let err = rejected(&format!(
        "{GOOD}\n[[report.landmark_reference]]\nlabel = \"T\"\nat = {{ \"odometry.var_x_m2\" = 9.0 }}\nlandmarks = []\n"
    ));
    assert!(
        err.contains("report.landmark_reference[0].at") && err.contains("no sweep point"),
        "{err}"
    );
}

/// A plan too large to expand is refused before anything is expanded, with the number and how to
/// raise the limit (issue: `replicates = 1e9` and a 1e9-point grid exhausted memory).
#[test]
fn plans_beyond_the_run_limit_are_refused_before_expansion() {
    let err = rejected(&GOOD.replace("replicates = 1", "replicates = 1000000000"));
    assert!(
        err.contains("bad.toml:4:1: key `replicates`")
            && err.contains("expands to 1000000000 runs")
            && err.contains("--max-runs"),
        "{err}"
    );
    let values: Vec<String> = (0..1000).map(|i| format!("{}", 0.001 * (i + 1) as f64)).collect();
    let list = values.join(", ");
    let grid = format!(
        "{GOOD}\n[[sweeps]]\nkind = \"grid\"\nvalues = {{ \"odometry.var_x_m2\" = [{list}], \"odometry.var_y_m2\" = [{list}], \"odometry.var_theta_rad2\" = [{list}] }}\n"
    );
    let started = std::time::Instant::now();
    let err = rejected(&grid);
    assert!(err.contains("key `sweeps`") && err.contains("expands to 1000000000 runs"), "{err}");
    assert!(started.elapsed().as_secs() < 60, "refused without expanding");
    // the limit is a flag: a smaller one refuses the smoke study (8 runs)
    let out = slamlab(&["validate", "experiments/smoke.toml", "--max-runs", "4"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(2)
            && err.contains("expands to 8 runs")
            && err.contains("limit of 4"),
        "{err}"
    );
}

#[test]
fn absurd_thread_counts_are_refused() {
    let work = tempfile::tempdir().unwrap();
    let out = slamlab(&[
        "run",
        "experiments/smoke.toml",
        "-j",
        "100000",
        "--results",
        s(&work.path().join("r")),
        "--cache",
        s(&work.path().join("c")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--threads 100000 is more than 1024"), "{err}");
    assert!(!work.path().join("r").exists() && !work.path().join("c").exists());
}

/// A results folder that cannot be written is found before any run, not after them: nothing is
/// computed or cached. (A path under a regular file fails for root too, unlike a chmod.)
#[test]
fn an_unwritable_results_folder_is_refused_before_any_run() {
    let work = tempfile::tempdir().unwrap();
    let file = work.path().join("not-a-dir");
    std::fs::write(&file, "x").unwrap();
    let results = file.join("results");
    let out = slamlab(&[
        "run",
        "experiments/smoke.toml",
        "--results",
        s(&results),
        "--cache",
        s(&work.path().join("c")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("cannot write results")
            && err.contains("not-a-dir")
            && err.contains("nothing was run"),
        "{err}"
    );
    assert!(!work.path().join("c").exists(), "nothing was computed or cached");
}

/// `make pdf`'s overfull-box check (tests/tools/pdf.sh) fails on a table wider than the text and
/// passes the same document with a table that fits. Skipped where pdflatex is not installed.
#[test]
fn the_pdf_check_catches_a_table_wider_than_the_text() {
    if std::process::Command::new("pdflatex").arg("--version").output().is_err() {
        eprintln!("skipped: pdflatex is not installed (make install-checkers)");
        return;
    }
    let work = tempfile::tempdir().unwrap();
    let doc = |columns: usize| {
        let cells = vec!["1234567890"; columns].join(" & ");
        format!(
            "\\documentclass[10pt,a4paper]{{article}}\n\\usepackage[margin=2cm]{{geometry}}\n\\begin{{document}}\n\\begin{{tabular}}{{{}}}\n{cells} \\\\\n\\end{{tabular}}\n\\end{{document}}\n",
            "r".repeat(columns)
        )
    };
    for (columns, fits) in [(4, true), (14, false)] {
        let reports = work.path().join(format!("reports-{columns}"));
        std::fs::create_dir_all(reports.join("wide")).unwrap();
        std::fs::write(reports.join("wide/wide.tex"), doc(columns)).unwrap();
        let out = std::process::Command::new("bash")
            .arg(repo().join("tests/tools/pdf.sh"))
            .arg(&reports)
            .arg(work.path().join(format!("pdf-{columns}")))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.success(), fits, "{columns} columns: {err}");
        if !fits {
            assert!(err.contains("overfull box") && err.contains("pt too wide"), "{err}");
        }
    }
}

/// `plan` names the parameters that changed for a "parameters changed" run, with both values.
#[test]
fn plan_names_the_parameters_that_changed() {
    let work = tempfile::tempdir().unwrap();
    let spec = std::fs::read_to_string(repo().join("experiments/smoke.toml")).unwrap();
    let path = work.path().join("smoke.toml");
    std::fs::write(&path, &spec).unwrap();
    let (results, cache) = (work.path().join("r"), work.path().join("c"));
    crate::util::ok(&["run", "-q", s(&path), "--results", s(&results), "--cache", s(&cache)]);
    std::fs::write(
        &path,
        spec.replace("[base.odometry]", "[base.sim]\ndt_s = 0.2\n\n[base.odometry]"),
    )
    .unwrap();
    let out = crate::util::ok(&["plan", s(&path), "--results", s(&results), "--cache", s(&cache)]);
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("parameters changed"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(line.contains("(sim.dt_s: 0.1 → 0.2)"), "{line}");
}

/// Invalid command-line values are usage errors (exit 2), like clap's own, and write nothing.
#[test]
fn invalid_command_line_values_exit_2() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache) = (work.path().join("results"), work.path().join("cache"));
    let dirs = ["--results", s(&results), "--cache", s(&cache)];
    let spec = "experiments/smoke.toml";
    let out_dir = work.path().join("slurm");
    for args in [
        vec!["run", spec, "--threads", "0"],
        vec!["plan", spec, "--shards", "0"],
        vec!["slurm", spec, "--tasks", "0", "--out", s(&out_dir)],
        vec!["slurm", spec, "--mem", "4GB", "--out", s(&out_dir)],
        vec!["slurm", spec, "--time", "soon", "--out", s(&out_dir)],
        vec!["diff", "a", "b", "--alpha", "2"],
        vec!["report", "--results", "no/such/folder", "--out", s(&out_dir)],
    ] {
        let mut args = args.clone();
        if args[0] != "diff" && args[0] != "report" && args[0] != "slurm" {
            args.extend(dirs);
        }
        let out = slamlab(&args);
        assert_eq!(
            out.status.code(),
            Some(2),
            "slamlab {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!results.exists() && !cache.exists() && !out_dir.exists(), "{args:?} wrote");
    }
}

/// A key set twice is named (toml itself says only "duplicate key").
#[test]
fn a_duplicate_key_is_named() {
    let err = rejected(&GOOD.replace("seed = 1\n", "seed = 1\nseed = 2\n"));
    assert!(err.contains("duplicate key `seed`"), "{err}");
}

/// A value rendered into a batch script cannot break out of it: a newline in a path is refused
/// (the review's `--out $'o\ntouch PWNED #'` wrote a script that ran `touch PWNED`), and so is a
/// path that is not valid UTF-8 (it silently became another folder).
#[test]
fn slurm_refuses_paths_a_script_cannot_hold() {
    use std::os::unix::ffi::OsStrExt;
    let work = tempfile::tempdir().unwrap();
    let newline = work.path().join("o\ntouch PWNED #");
    let out = slamlab(&["slurm", "experiments/smoke.toml", "--out", s(&newline)]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!newline.exists());
    let bad = work.path().join(std::ffi::OsStr::from_bytes(b"x\xff"));
    let out_dir = work.path().join("out");
    let out = crate::util::slamlab_os(&[
        "slurm".as_ref(),
        "experiments/smoke.toml".as_ref(),
        "--cache".as_ref(),
        bad.as_os_str(),
        "--out".as_ref(),
        out_dir.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!out_dir.exists() && !bad.exists());
}

/// A spec reads only inside its folders: a map is a name in --maps, a published table a relative
/// path without `..` (the review read /etc/passwd and another folder's files).
#[test]
fn spec_paths_are_confined() {
    let err = rejected(
        &GOOD.replace("maps = [\"recinto_basico\"]", "maps = [\"../../experiments/smoke\"]"),
    );
    assert!(err.contains("maps[0]") && err.contains("not a map name"), "{err}");
    let err = rejected(&format!(
        "{GOOD}\n[report]\nreference = {{ file = \"../../../../etc/passwd\", experiments = [\"x\"], label = \"[FT]\" }}\n"
    ));
    assert!(
        err.contains("report.reference.file") && err.contains("leaves the working folder"),
        "{err}"
    );
}

/// A spec file has a size limit: `validate /dev/zero` is refused at once instead of reading
/// without end (the review reached 17 GB).
#[test]
fn an_endless_spec_is_refused() {
    let out = slamlab(&["validate", "/dev/zero"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("the most a spec may be"));
}

/// A design range outside its parameter's domain is reported once, at the bound (the review saw
/// one error per sampled point, with random values, and the bound never named).
#[test]
fn a_bad_design_bound_is_reported_once_at_the_bound() {
    let spec = GOOD
        .replace("maps = [\"recinto_basico\"]", "maps = [\"bigloop2\"]")
        .replace("algorithms = [\"odometry\"]", "algorithms = [\"fastslam1\"]")
        + "\n[[sweeps]]\nkind = \"sobol\"\nsamples = 16\nranges = { \"fastslam.particles\" = [0, 10], \"fastslam.obs_var_rho_m2\" = [-1.0, 1.0] }\n";
    let err = rejected(&spec);
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("bad.toml:")).collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(lines.iter().all(|l| l.contains("lower bound")), "{err}");
}

/// `[sequential] items` (published items staged beside the claims) is checked when the study is
/// planned: the items need the study's reference rows, the file must be readable, and it must hold
/// an item this study answers by published cells.
#[test]
fn staged_items_are_checked_when_planned() {
    let sequential = GOOD.replace("replicates = 1", "replicates = 3\nmax_replicates = 6");
    let with = |extra: &str| format!("{sequential}\n[sequential]\n{extra}\n");
    let err = rejected(&with("items = \"data/reference/published-results.toml\""));
    assert!(err.contains("sequential.items") && err.contains("[report] reference"), "{err}");
    let err = rejected(&with("items = \"no/such/items.toml\""));
    assert!(err.contains("sequential.items") && err.contains("cannot read"), "{err}");
    // a budget no larger than the first stage takes one look: nothing could be staged
    let one_look = GOOD.replace("replicates = 1", "replicates = 3\nmax_replicates = 3");
    let err = rejected(&format!(
        "{one_look}\n[sequential]\nitems = \"data/reference/published-results.toml\"\n"
    ));
    assert!(err.contains("sequential.items") && err.contains("need looks"), "{err}");
}
