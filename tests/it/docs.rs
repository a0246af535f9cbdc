//! Contract: the book's generated chapters (`docs/src/reference/cli.md`, `algorithms.md`,
//! `modelling-defaults.md`, `parameters-generated.md`) are what `slamlab docs` writes from the code
//! now — the command line's own help, the algorithm registry, each model's `describe()` and the
//! parameter structs' doc comments — so that a new flag, algorithm, modelling choice or parameter
//! cannot be missing from the book; and the README stays within 250 lines.

use crate::util::{ok, repo};

#[test]
fn the_books_generated_chapters_are_current() {
    let dir = tempfile::tempdir().unwrap();
    ok(&["docs", dir.path().to_str().unwrap()]);
    for name in ["cli.md", "algorithms.md", "modelling-defaults.md", "parameters-generated.md"] {
        let generated = std::fs::read_to_string(dir.path().join(name)).unwrap();
        let committed = std::fs::read_to_string(repo().join("docs/src/reference").join(name))
            .unwrap_or_default();
        assert!(
            generated == committed,
            "docs/src/reference/{name} is out of date: run `make docs` (or `slamlab docs docs/src/reference`)"
        );
    }
    // every built-in and the repository's external example are in the algorithm chapter, and every
    // subcommand in the command-line chapter
    let algorithms = std::fs::read_to_string(dir.path().join("algorithms.md")).unwrap();
    for name in ["odometry", "fastslam1", "ekf_slam", "psm", "tnewton", "ekf_slam_py", "pose_graph"]
    {
        assert!(algorithms.contains(&format!("| `{name}` |")), "{name} missing");
    }
    let cli = std::fs::read_to_string(dir.path().join("cli.md")).unwrap();
    for command in ["run", "report", "validate", "plan", "diff", "algorithms", "slurm", "docs"] {
        assert!(cli.contains(&format!("## `slamlab {command}`")), "{command} missing");
    }
    assert!(cli.contains("--threads"), "the flags are in the chapter");
    let parameters = std::fs::read_to_string(dir.path().join("parameters-generated.md")).unwrap();
    for key in ["| `particles` |", "| `dmax_m` |", "| `front_end` |", "| `precision` |"] {
        assert!(parameters.contains(key), "{key} missing from the parameter chapter");
    }
    let models = std::fs::read_to_string(dir.path().join("modelling-defaults.md")).unwrap();
    for heading in
        ["### `fastslam1`", "### `psm_original`", "### `graph_slam`", "## The simulated world"]
    {
        assert!(models.contains(heading), "{heading} missing from the modelling chapter");
    }
}

#[test]
fn the_readme_is_a_five_minute_read() {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(lines <= 250, "README.md has {lines} lines: move the detail into the book (docs/)");
}

/// The book's annotated example spec is a valid study (the chapter includes the file itself).
#[test]
fn the_books_example_spec_validates() {
    let out = ok(&["validate", repo().join("docs/examples/example-study.toml").to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("ok: "), "validate reports the spec");
}

/// The README's minimal study is `experiments/smoke.toml` itself (GitHub Markdown cannot include a
/// file): every line of its TOML block but the shortened description is a line of the file.
#[test]
fn the_readmes_study_is_the_smoke_spec() {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let smoke = std::fs::read_to_string(repo().join("experiments/smoke.toml")).unwrap();
    let start = readme.find("```toml\n").expect("the README shows a study") + "```toml\n".len();
    let block = &readme[start..start + readme[start..].find("```").unwrap()];
    let lines: Vec<&str> = block.lines().filter(|l| !l.starts_with("description")).collect();
    assert!(lines.len() > 10, "the README's study is a whole spec");
    for line in lines {
        assert!(
            smoke.lines().any(|l| l == line),
            "README's study line {line:?} is not in experiments/smoke.toml"
        );
    }
}
