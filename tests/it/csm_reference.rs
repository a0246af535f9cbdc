//! Contract: `pl_icp` is PL-ICP as Censi's CSM computes it (`sm2`'s defaults). On the 2 727
//! consecutive Intel-lab pairs of `ep-intel` (three replicates of perturbed guesses), slamlab's
//! estimates agree with CSM's outputs in `data/reference/csm-intel/` (its README: the build, the
//! driver, the parameters) within 1 mm and 0.05° on at least 99 % of the matches, and the two have
//! the same accuracy against the corrected poses. The few that differ stop after another number
//! of iterations: CSM detects a repeated correspondence set by a 31-bit hash and searches
//! correspondences in a window of ±90° and 0.5 m (`max_angular_correction_deg`,
//! `max_linear_correction`), slamlab compares the sets themselves and searches exactly.
//! Skipped with a message when `../shared/data/intel-lab` is absent.

use crate::util::{ok, repo, s};
use slamlab::geom::{Pose2, wrap_angle};
use slamlab::store;

/// One row of `csm-intel.csv`: CSM's estimate (`None` when it reported failure), the truth and
/// the guess.
struct Row {
    csm: Option<Pose2>,
    truth: Pose2,
    guess: Pose2,
}

fn rows() -> Vec<Row> {
    let text = std::fs::read_to_string(repo().join("data/reference/csm-intel/csm-intel.csv"))
        .expect("data/reference/csm-intel/csm-intel.csv is committed");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let col = |k: &str| header.iter().position(|h| *h == k).unwrap_or_else(|| panic!("column {k}"));
    lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            let pose = |x: &str, y: &str, t: &str| {
                let num = |k: &str| f[col(k)].parse::<f64>().unwrap_or_else(|_| panic!("{k}"));
                Pose2::new(num(x), num(y), num(t))
            };
            Row {
                csm: (f[col("csm_valid")] == "1")
                    .then(|| pose("csm_x_m", "csm_y_m", "csm_theta_rad")),
                truth: pose("truth_x_m", "truth_y_m", "truth_theta_rad"),
                guess: pose("guess_x_m", "guess_y_m", "guess_theta_rad"),
            }
        })
        .collect()
}

/// Translation [mm] and rotation [°] between two poses.
fn apart(a: Pose2, b: Pose2) -> (f64, f64) {
    ((a.x - b.x).hypot(a.y - b.y) * 1e3, wrap_angle(a.theta - b.theta).abs().to_degrees())
}

/// Median and 90th percentile of translation and rotation errors, and the gross count
/// (> 0.2 m or > 5°), a match without an estimate scored at its guess.
fn accuracy(estimates: &[(Option<Pose2>, Pose2, Pose2)]) -> ([f64; 4], usize) {
    let errors: Vec<(f64, f64)> =
        estimates.iter().map(|(e, truth, guess)| apart(e.unwrap_or(*guess), *truth)).collect();
    let quantile = |mut v: Vec<f64>, q: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * q).round() as usize]
    };
    let t: Vec<f64> = errors.iter().map(|e| e.0).collect();
    let r: Vec<f64> = errors.iter().map(|e| e.1).collect();
    let gross = errors.iter().filter(|(t, r)| *t > 200.0 || *r > 5.0).count();
    (
        [quantile(t.clone(), 0.5), quantile(t, 0.9), quantile(r.clone(), 0.5), quantile(r, 0.9)],
        gross,
    )
}

#[test]
fn pl_icp_agrees_with_csm_on_the_intel_pairs() {
    if !repo().join("../shared/data/intel-lab").is_dir() {
        eprintln!("skipped: csm_reference: ../shared/data/intel-lab is absent");
        return;
    }
    let spec = std::fs::read_to_string(repo().join("experiments/ep-intel.toml")).unwrap();
    let head = &spec[..spec.find("[[claims]]").unwrap_or(spec.len())];
    let algorithms = head.lines().find(|l| l.starts_with("algorithms = ")).expect("algorithms");
    let work = tempfile::tempdir().unwrap();
    let path = work.path().join("ep-intel.toml");
    std::fs::write(&path, head.replace(algorithms, "algorithms = [\"pl_icp\"]")).unwrap();
    let results = work.path().join("results");
    let cache = work.path().join("cache");
    ok(&["run", "-q", s(&path), "--results", s(&results), "--cache", s(&cache)]);
    let mut runs = store::read_matches(&results.join("ep-intel"), &|_| true).unwrap();
    runs.sort_by(|a, b| a.run_id.cmp(&b.run_id));
    let ours: Vec<_> = runs.iter().flat_map(|r| &r.matches).collect();
    let reference = rows();
    assert_eq!(ours.len(), reference.len(), "the pairs of ep-intel changed: regenerate csm-intel");
    let mut agree = 0;
    for (m, row) in ours.iter().zip(&reference) {
        assert!(
            apart(m.initial, row.guess).0 < 1e-9 && apart(m.truth, row.truth).0 < 1e-9,
            "pair {} → {}: not the pair CSM matched",
            m.reference_step,
            m.current_step
        );
        if let Some(csm) = row.csm {
            let (dt, dr) = apart(m.estimate, csm);
            agree += usize::from(dt <= 1.0 && dr <= 0.05);
        }
    }
    eprintln!("csm_reference: {agree} of {} matches within 1 mm and 0.05° of CSM", ours.len());
    assert!(agree * 100 >= ours.len() * 99, "{agree} of {} agree with CSM", ours.len());
    let finite = |p: Pose2| p.is_finite().then_some(p);
    let (slam, slam_gross) = accuracy(
        &ours.iter().map(|m| (finite(m.estimate), m.truth, m.initial)).collect::<Vec<_>>(),
    );
    let (csm, csm_gross) =
        accuracy(&reference.iter().map(|r| (r.csm, r.truth, r.guess)).collect::<Vec<_>>());
    eprintln!(
        "csm_reference: slamlab {slam:.3?} gross {slam_gross}; CSM {csm:.3?} gross {csm_gross}"
    );
    // the same accuracy to the reports' precision: 0.1 mm, 0.001°, and the gross count
    for (k, (a, b)) in slam.iter().zip(&csm).enumerate() {
        let tolerance = if k < 2 { 0.1 } else { 0.001 };
        assert!((a - b).abs() <= tolerance, "statistic {k}: slamlab {a} against CSM {b}");
    }
    assert_eq!(slam_gross, csm_gross);
}
