//! Contract: morris and sobol sweeps run end to end — design → runs → indices → report section,
//! `sensitivity.csv` and index claims — byte-identical whatever the thread count; and on dead
//! reckoning with additive pose noise they find what physics says: heading noise, which rotates
//! every later step, drives the trajectory error far more than position noise.

use crate::util::run_and_report;

/// The study (a file: its name must match its id).
const SPEC: &str = "tests/specs/gsa.toml";

#[test]
fn design_sweeps_end_to_end_and_thread_independent() {
    let dir = tempfile::tempdir().unwrap();
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    run_and_report(SPEC, &one, "1");
    run_and_report(SPEC, &two, "2");
    let report =
        |w: &std::path::Path, f: &str| std::fs::read(w.join("reports/gsa").join(f)).unwrap();
    for f in ["index.html", "gsa.tex", "sensitivity.csv", "claims.json"] {
        assert!(report(&one, f) == report(&two, f), "{f} differs between 1 and 2 threads");
    }
    // the design rows in design order: 6 trajectories of 4 points, then N (d + 2) = 160 rows
    let csv = String::from_utf8(report(&one, "sensitivity.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 6 * 4 + 32 * 5);
    assert!(
        rows[24].contains(",A0,")
            && rows[24 + 32].contains(",B0,")
            && rows[24 + 64].contains(",AB0:odometry.var_x_m2,"),
        "{}",
        rows[24]
    );
    assert!(
        rows.iter().all(|r| !r.split(',').nth(7).unwrap().is_empty()),
        "every row has an output"
    );
    let html = String::from_utf8(report(&one, "index.html")).unwrap();
    assert!(
        html.contains("Sobol&#39; indices")
            && html.contains("Morris screening")
            && html.contains("Ranking by ST: var_theta_rad2"),
        "heading noise ranks first"
    );
    assert!(
        std::fs::metadata(
            one.join("reports/gsa/figures/sensitivity-g1-recinto-basico-odometry-ate-rmse-m.svg")
        )
        .is_ok()
    );
    let claims: Vec<serde_json::Value> =
        serde_json::from_slice(&report(&one, "claims.json")).unwrap();
    let verdicts: Vec<(&str, &str)> = claims
        .iter()
        .map(|c| (c["id"].as_str().unwrap(), c["verdict"].as_str().unwrap()))
        .collect();
    assert_eq!(
        verdicts,
        [("heading-dominates", "confirmed"), ("heading-screens-first", "confirmed")],
        "{claims:#?}"
    );
}
