//! Plain-text scans and scan pairs, so a peer implementation (Diosi's PSM C program, say) can
//! match exactly the scans a slamlab run matched: `slamlab export-scans`.
//!
//! - `scans.txt`: one scan per line, `step n_beams angle_min_rad angle_increment_rad r_0 … r_{n−1}`
//!   (x forward, bearings counter-clockwise, ranges in metres, `inf` for no return);
//! - `pairs.txt`: one match per line, `ref_step cur_step guess_x_m guess_y_m guess_theta_rad`
//!   (the current scan's pose in the reference scan's frame, as the matcher started from it);
//! - `matches.txt`: the same pairs with the true pose change and slamlab's estimate and stop.
//!
//! Reals are written in Rust's shortest round-trip form, so they read back bit for bit.

use crate::scanmatch::track::Pair;
use crate::trace::MatchRecord;
use std::fmt::Write;

/// `pairs.txt` of a run's matches.
pub fn pairs_text(matches: &[MatchRecord]) -> String {
    let pairs: Vec<Pair> = matches
        .iter()
        .map(|m| Pair {
            reference_step: m.reference_step,
            current_step: m.current_step,
            initial: m.initial,
        })
        .collect();
    crate::scanmatch::track::pairs_text(&pairs)
}

/// `matches.txt`: each pair with the truth and slamlab's estimate.
pub fn matches_text(matches: &[MatchRecord]) -> String {
    let mut s = String::from(
        "# ref_step cur_step truth_x_m truth_y_m truth_theta_rad estimate_x_m estimate_y_m estimate_theta_rad iterations stop\n",
    );
    for m in matches {
        let _ = writeln!(
            s,
            "{} {} {} {} {} {} {} {} {} {}",
            m.reference_step,
            m.current_step,
            m.truth.x,
            m.truth.y,
            m.truth.theta,
            m.estimate.x,
            m.estimate.y,
            m.estimate.theta,
            m.iterations,
            m.stop
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Pose2;
    use crate::world::laser::{LaserGeometry, Scan, scans_text};

    #[test]
    fn scans_and_pairs_read_back_bit_for_bit() {
        let geometry = LaserGeometry {
            angle_min_rad: -std::f64::consts::FRAC_PI_2,
            angle_increment_rad: 1f64.to_radians(),
            beams: 3,
            max_range_m: 10.0,
        };
        let text = scans_text(
            &geometry,
            &[Scan { step: 7, ranges_m: vec![Some(0.1 + 0.2), None, Some(2.5)] }],
        );
        let line = text.lines().nth(1).unwrap();
        let f: Vec<&str> = line.split(' ').collect();
        assert_eq!(f[..2], ["7", "3"]);
        assert_eq!(f[2].parse::<f64>().unwrap(), -std::f64::consts::FRAC_PI_2);
        assert_eq!(f[4].parse::<f64>().unwrap(), 0.1 + 0.2);
        assert_eq!(f[5], "inf");
        let m = MatchRecord {
            reference_step: 3,
            current_step: 9,
            truth: Pose2::new(0.5, 0.0, 0.1),
            initial: Pose2::new(0.51, -0.02, 1.0 / 3.0),
            estimate: Pose2::new(0.49, 0.01, 0.1),
            f: 1.0,
            f_initial: 2.0,
            pairs: 100,
            iterations: 12,
            evaluations: 12,
            fallback: false,
            stop: "Converged".into(),
            time_s: 0.0,
        };
        let pairs = pairs_text(std::slice::from_ref(&m));
        let f: Vec<&str> = pairs.lines().nth(1).unwrap().split(' ').collect();
        assert_eq!(f[..2], ["3", "9"]);
        assert_eq!(f[4].parse::<f64>().unwrap(), 1.0 / 3.0);
        assert!(matches_text(&[m]).lines().nth(1).unwrap().ends_with(" 12 Converged"));
    }
}
