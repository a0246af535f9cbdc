//! Contract of `slamlab diff`: the same code twice ⇒ "identical" everywhere; a deliberate change
//! (FastSLAM's particle count cut) ⇒ its cells flagged "regressed" with a CI excluding zero, the
//! untouched study identical, and the parameter difference listed first.

use crate::util::{ok, s};

const FASTSLAM: &str = r#"
id = "diff-fastslam"
title = "diff test: FastSLAM particles"
seed = 5
replicates = 6
maps = ["scatter"]
algorithms = ["fastslam1"]

[base.odometry]
model = "proportional"
k = 0.1
k_is = "std"

[base.landmark_sensor]
max_range_m = 15.0
rate_hz = 5.0
range_sigma_m = 0.1
bearing_sigma_rad = 0.0175

[base.motion_model]
model = "proportional"
k_translation = 0.1
k_rotation = 0.1

[base.fastslam]
particles = PARTICLES
association = "known"

[report]
metrics = ["ate_rmse_m", "map_rmse_m"]

# a change of the map error below 10 000 % of its BASE value is "within noise" for this study
# (one particle raises it about 30-fold on this world)
[report.diff.metrics.map_rmse_m]
min_effect = 100.0
"#;

fn run(work: &std::path::Path, particles: &str) -> std::path::PathBuf {
    let specs = work.join("specs");
    std::fs::create_dir_all(&specs).unwrap();
    let spec = specs.join("diff-fastslam.toml");
    std::fs::write(&spec, FASTSLAM.replace("PARTICLES", particles)).unwrap();
    let results = work.join("results");
    let cache = work.join("cache");
    for spec in [spec.as_path(), crate::util::repo().join("experiments/smoke.toml").as_path()] {
        ok(&["run", s(spec), "--quiet", "--results", s(&results), "--cache", s(&cache)]);
    }
    results
}

#[test]
fn same_code_is_identical_and_a_particle_cut_regresses() {
    let (a, b, c) =
        (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let base = run(a.path(), "50");
    let same = run(b.path(), "50");
    let cut = run(c.path(), "1");

    let text = String::from_utf8(ok(&["diff", s(&base), s(&same)]).stdout).unwrap();
    assert!(
        !text.contains("parameters differ")
            && !text.contains("regressed")
            && !text.contains("improved"),
        "{text}"
    );
    assert!(
        text.contains("comparisons: ") && text.contains(" identical;") && text.contains("0 tests"),
        "{text}"
    );

    let text = String::from_utf8(ok(&["diff", s(&base), s(&cut)]).stdout).unwrap();
    assert!(
        text.starts_with("diff-fastslam: parameters differ\n  base.fastslam.particles: 50 → 1"),
        "{text}"
    );
    let line = text.lines().find(|l| l.contains("ate_rmse_m")).expect("an ATE row");
    assert!(line.contains("regressed"), "{line}");
    // the study's own min-effect for the map error
    let line = text.lines().find(|l| l.contains("map_rmse_m")).expect("a map-error row");
    assert!(line.contains("within_noise"), "{line}");
    // the smoke study is untouched: only identical rows, which the table does not list
    assert!(!text.lines().any(|l| l.starts_with("smoke ")), "{text}");

    // the HTML/LaTeX diff report overlays BASE and NEW
    let report = c.path().join("diff-report");
    ok(&["diff", s(&base), s(&cut), "--report", s(&report)]);
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(
        html.contains("base.fastslam.particles: 50 → 1")
            && html.contains("(BASE)")
            && html.contains("(NEW)")
            && html.contains("<svg"),
        "diff report lacks its parts"
    );
    assert!(
        report.join("diff.tex").is_file()
            && report.join("figures/diff-fastslam--g0--ate-rmse-m.tex").is_file()
    );

    let md = String::from_utf8(ok(&["diff", s(&base), s(&cut), "--md"]).stdout).unwrap();
    assert!(
        md.starts_with("## slamlab diff")
            && md.contains("| diff-fastslam |")
            && md.contains("regressed"),
        "{md}"
    );
}
