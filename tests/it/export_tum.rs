//! `slamlab export-tum`: TUM files for every run, consistent with the stored metrics (evo would
//! compute the same ATE from them).

use crate::util::{ok, s};
use slamlab::store;

fn read_tum(path: &std::path::Path) -> Vec<[f64; 8]> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
            v.try_into().unwrap()
        })
        .collect()
}

#[test]
fn exported_trajectories_reproduce_the_stored_ate() {
    let work = tempfile::tempdir().unwrap();
    let (results, cache, out) =
        (work.path().join("results"), work.path().join("cache"), work.path().join("tum"));
    ok(&[
        "run",
        "experiments/smoke.toml",
        "--quiet",
        "--results",
        s(&results),
        "--cache",
        s(&cache),
    ]);
    ok(&["export-tum", s(&results.join("smoke")), s(&out)]);
    let runs = store::read_runs(&results.join("smoke")).unwrap();
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 2 * runs.len());
    for r in &runs {
        let gt = read_tum(&out.join(format!("{}.gt.tum", r.run_id)));
        let est = read_tum(&out.join(format!("{}.est.tum", r.run_id)));
        assert_eq!(gt.len(), est.len());
        assert!(gt.iter().zip(&est).all(|(a, b)| a[0] == b[0]), "timestamps pair up");
        // unit quaternions about z
        assert!(
            gt.iter().all(|p| (p[6] * p[6] + p[7] * p[7] - 1.0).abs() < 1e-9
                && p[4] == 0.0
                && p[5] == 0.0)
        );
        let rmse = (gt
            .iter()
            .zip(&est)
            .map(|(a, b)| (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
            .sum::<f64>()
            / gt.len() as f64)
            .sqrt();
        let stored = r.metric("ate_rmse_m").unwrap();
        assert!((rmse - stored).abs() < 1e-6, "{}: {rmse} vs {stored}", r.run_id);
    }
    // one run only, from the results root
    let one = work.path().join("one");
    ok(&["export-tum", s(&results), s(&one), "--run", &runs[0].run_id]);
    assert!(one.join("smoke").join(format!("{}.est.tum", runs[0].run_id)).is_file());
}
