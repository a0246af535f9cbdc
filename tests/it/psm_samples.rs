//! Contract: on real scans without ground truth (the PSM distribution's 126 SICK LMS-200 scans),
//! the matchers agree with each other: PSM as published (its own heuristics) and E-PSM / CRS2
//! (line segmentation) find the same pose change for consecutive scans, starting from the
//! odometry. Skipped with a message when `../shared/data/psm-sample-scans` is absent.

use slamlab::dataset::psm_samples::{
    self, ANGLE_INCREMENT_RAD, ANGLE_MIN_RAD, MAX_RANGE_M, SampleScan,
};
use slamlab::geom::{Pose2, wrap_angle};
use slamlab::scanmatch::epsm::{EpsmParams, epsm};
use slamlab::scanmatch::objective::{Objective, ObjectiveParams};
use slamlab::scanmatch::psm::{PsmParams, psm};
use slamlab::scanmatch::search::{Optimizer, SearchParams, simultaneous};
use slamlab::scanmatch::segment::{Segmentation, SegmentationParams, prepare};

fn scans() -> Option<Vec<SampleScan>> {
    let folder = crate::util::repo().join("../shared/data/psm-sample-scans");
    if !folder.is_dir() {
        eprintln!("skipped: psm_samples: real scan folder {} is absent", folder.display());
        return None;
    }
    Some(psm_samples::load(&folder).expect("the sample scans read"))
}

fn pose_change(s: &[SampleScan], k: usize, method: Segmentation, matcher: &str) -> Option<Pose2> {
    let seg = SegmentationParams { method, ..SegmentationParams::default() };
    let prep = |scan: &SampleScan| {
        prepare(&scan.ranges_m, ANGLE_MIN_RAD, ANGLE_INCREMENT_RAD, MAX_RANGE_M, &seg)
    };
    let (r, c) = (prep(&s[k]), prep(&s[k + 1]));
    let guess = s[k + 1].odometry.relative_to(s[k].odometry);
    let params = ObjectiveParams::default();
    let mut cost = Objective::new(&r, &c, &params);
    let m = match matcher {
        "psm" => psm(&r, &c, guess, &PsmParams::default(), &mut cost).unwrap(),
        "epsm" => epsm(&mut cost, guess, &EpsmParams::default()),
        _ => simultaneous(&mut cost, guess, Optimizer::Crs2, &SearchParams::default(), k as u64),
    };
    (m.pose.is_finite() && m.f.is_finite()).then_some(m.pose)
}

fn close(a: Pose2, b: Pose2, metres: f64, degrees: f64) -> bool {
    a.position().distance(b.position()) < metres
        && wrap_angle(a.theta - b.theta).abs().to_degrees() < degrees
}

#[test]
fn matchers_agree_on_the_psm_sample_scans() {
    let Some(s) = scans() else { return };
    let pairs = s.len() - 1;
    let (mut epsm_crs2, mut psm_epsm, mut failed) = (0, 0, 0);
    let (mut d_ec, mut d_pe) = (Vec::new(), Vec::new());
    for k in 0..pairs {
        let (p, e, c) = (
            pose_change(&s, k, Segmentation::PsmHeuristics, "psm"),
            pose_change(&s, k, Segmentation::Lines, "epsm"),
            pose_change(&s, k, Segmentation::Lines, "crs2"),
        );
        match (p, e, c) {
            (Some(p), Some(e), Some(c)) => {
                epsm_crs2 += close(e, c, 0.05, 2.0) as usize;
                psm_epsm += close(p, e, 0.05, 2.0) as usize;
                d_ec.push(e.position().distance(c.position()));
                d_pe.push(p.position().distance(e.position()));
            }
            _ => failed += 1,
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (m_ec, m_pe) = (median(&mut d_ec), median(&mut d_pe));
    eprintln!(
        "psm samples: {pairs} pairs; within 5 cm and 2°: E-PSM/CRS2 {epsm_crs2}, PSM/E-PSM {psm_epsm}; median position disagreement {:.1} / {:.1} mm; {failed} failed",
        m_ec * 1e3,
        m_pe * 1e3
    );
    assert!(failed <= pairs / 20, "{failed} of {pairs} pairs had a failed match");
    // the two searches of the same objective agree closely in most pairs; PSM, with its own
    // preprocessing and error measure, less closely
    assert!(
        epsm_crs2 * 10 >= pairs * 8 && m_ec < 0.01,
        "E-PSM and CRS2: {epsm_crs2} of {pairs} pairs agree, median {m_ec} m"
    );
    assert!(
        psm_epsm * 10 >= pairs * 8 && m_pe < 0.03,
        "PSM and E-PSM: {psm_epsm} of {pairs} pairs agree, median {m_pe} m"
    );
}
