//! The sample scans of Diosi & Kleeman's PSM distribution (`../shared/data/psm-sample-scans`):
//! `sick_lms200.log`, 126 scans of a SICK LMS-200 with the robot's odometry, as read by the
//! distribution's `read_scan4`. No ground truth: they serve matcher-agreement tests and benchmarks
//! on real scans.
//!
//! Format: a header line, then one scan per line: `time_ms x y θ r0 … r180` — x, y in cm, θ in
//! degrees (odometry), 181 ranges in mm over the front 180° at 1° (right to left). Choices: ranges
//! of `max_range_m` or more are no return (the log writes 327630 mm for none; PSM's LMS-200 range is
//! 10 m); the bearings are −90° + i·1° (the distribution's code steps by 180°/182, a quirk [EP]'s
//! write-up notes; the scanner's own step is 1°).

use super::{DatasetError, LineError, read_text};
use crate::geom::Pose2;
use std::path::Path;

/// The file read.
pub const FILE_NAME: &str = "sick_lms200.log";
/// Beams per scan.
pub const BEAMS: usize = 181;
/// PSM's PM_MAX_RANGE for the LMS-200 [m].
pub const MAX_RANGE_M: f64 = 10.0;
/// Bearing of beam 0 and the step [rad].
pub const ANGLE_MIN_RAD: f64 = -std::f64::consts::FRAC_PI_2;
pub const ANGLE_INCREMENT_RAD: f64 = std::f64::consts::PI / 180.0;

/// One scan with the odometry pose it was taken at.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleScan {
    pub line: usize,
    pub time_ms: f64,
    /// Odometry pose [m, m, rad].
    pub odometry: Pose2,
    /// Ranges [m]; `None` = no return (or beyond [`MAX_RANGE_M`]).
    pub ranges_m: Vec<Option<f64>>,
}

/// Parses `sick_lms200.log` text (the first line is a header).
pub fn parse(text: &str) -> Result<Vec<SampleScan>, LineError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate().skip(1) {
        let line = i + 1;
        if raw.trim().is_empty() {
            continue;
        }
        let values: Vec<f64> = raw
            .split_whitespace()
            .enumerate()
            .map(|(k, t)| {
                t.parse::<f64>().map_err(|_| {
                    LineError::new(line, format!("field {}: `{t}` is not a number", k + 1))
                })
            })
            .collect::<Result<_, _>>()?;
        if values.len() != 4 + BEAMS {
            return Err(LineError::new(
                line,
                format!(
                    "expected {} fields (time, x, y, θ, {BEAMS} ranges), found {}",
                    4 + BEAMS,
                    values.len()
                ),
            ));
        }
        let odometry = Pose2::new(values[1] / 100.0, values[2] / 100.0, values[3].to_radians());
        let ranges_m = values[4..]
            .iter()
            .map(|&mm| mm / 1000.0)
            .map(|r| (r.is_finite() && r > 0.0 && r < MAX_RANGE_M).then_some(r))
            .collect();
        out.push(SampleScan { line, time_ms: values[0], odometry, ranges_m });
    }
    Ok(out)
}

/// Reads the scans from the sample folder.
pub fn load(folder: &Path) -> Result<Vec<SampleScan>, DatasetError> {
    let path = folder.join(FILE_NAME);
    parse(&read_text(&path)?).map_err(|e| e.in_file(&path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(t: u32, x: f64) -> String {
        let ranges: Vec<String> = (0..BEAMS)
            .map(|b| if b == 3 { "327630".into() } else { format!("{}", 1000 + b) })
            .collect();
        format!("{t} {x} 15.7 90.0 {}", ranges.join(" "))
    }

    #[test]
    fn parses_units_and_no_returns() {
        let text = format!("NEW_LOG_ENTRY header\n{}\n{}\n", line(1, -677.6), line(2, -650.0));
        let scans = parse(&text).unwrap();
        assert_eq!(scans.len(), 2);
        assert_eq!(scans[0].line, 2);
        assert!(
            (scans[0].odometry.x + 6.776).abs() < 1e-12
                && (scans[0].odometry.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-12
        );
        assert_eq!(scans[0].ranges_m[3], None);
        assert_eq!(scans[0].ranges_m[4], Some(1.004));
        let err = parse("h\n1 2 3\n").unwrap_err();
        assert_eq!(err.line, 2);
        let err = parse(&format!("h\n{}\n", line(1, 0.0).replace(" 1005 ", " x "))).unwrap_err();
        assert!(err.message.contains("`x`"), "{}", err.message);
    }

    #[test]
    fn real_samples_read_when_present() {
        if !super::super::test_data::available(
            "psm-sample-scans",
            "psm_samples::real_samples_read_when_present",
        ) {
            return;
        }
        let scans = load(
            &super::super::test_data::repository_root().join("../shared/data/psm-sample-scans"),
        )
        .unwrap();
        assert_eq!(scans.len(), 126);
        assert!(scans.iter().all(|s| s.ranges_m.iter().filter(|r| r.is_some()).count() > 100));
    }
}
