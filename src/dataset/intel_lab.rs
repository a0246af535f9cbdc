//! Intel Research Lab, Seattle (D. Hähnel, 2003), the "corrected" CARMEN log
//! (`intel-corrected.log.gz`: GMapping-corrected poses, as Radish's `intel.gfs.log`) → [`World`]
//! for scan matching against the corrected relative poses.
//!
//! Format: one message per line; only `FLASER` lines are read:
//! `FLASER 180 r0 … r179 x y θ odom_x odom_y odom_θ ipc_timestamp hostname logger_timestamp`
//! (ranges and positions in m, angles in rad). Other messages (`ODOM`, `NEFF`, `PARAM`, comments)
//! are skipped.
//!
//! Choices:
//! - **Beams.** 180 beams at 1° from −90° (right) to +89° (CARMEN's `FLASER 180` of a SICK
//!   LMS-200 at 1°: the increment is the field of view over the beam count). A range at or beyond
//!   `max_range_m` (the log writes 81.83 m for "no return") is no return.
//! - **Steps.** One step per scan: `truth[k]` is scan k's corrected pose, `odometry[k]` the exact
//!   relative pose from scan k to k + 1 (the log has no raw odometry — its laser, odometry and
//!   corrected poses are the same numbers). A scan-matching study perturbs these increments with
//!   its `[odometry]` model to make the initial guesses (see `world::odometry`).
//!   `World::dt_s` is the median interval between scans (the log's timestamps are re-based and
//!   irregular: mean 2.95 s).
//! - **Window.** `first_scan` and `scans` (0 = to the end) select consecutive scans.

use super::{DatasetError, LineError, read_gz_text};
use crate::geom::Pose2;
use crate::world::World;
use crate::world::laser::{LaserGeometry, Scan};
use std::path::Path;

/// The file read.
pub const FILE_NAME: &str = "intel-corrected.log.gz";

/// Beams per `FLASER 180` scan.
pub const BEAMS: usize = 180;

/// Default range [m] from which a reading is no return: the log's "no return" value is 81.83 m;
/// a SICK LMS-200 reaches about 80 m, but the lab's walls are within 20 m, so anything beyond
/// 40 m is treated as no return.
pub const DEFAULT_MAX_RANGE_M: f64 = 40.0;

/// One `FLASER` record.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserRecord {
    pub line: usize,
    pub ranges_m: Vec<f64>,
    /// The corrected laser pose.
    pub pose: Pose2,
    pub time_s: f64,
}

/// Parses every `FLASER` line of a CARMEN log.
pub fn parse(text: &str) -> Result<Vec<LaserRecord>, LineError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let mut tokens = raw.split_whitespace();
        if tokens.next() != Some("FLASER") {
            continue;
        }
        let fields: Vec<&str> = tokens.collect();
        let number = |k: usize, what: &str| -> Result<f64, LineError> {
            let t = fields.get(k).ok_or_else(|| {
                LineError::new(line, format!("FLASER: missing {what} (field {})", k + 2))
            })?;
            t.parse::<f64>()
                .map_err(|_| LineError::new(line, format!("FLASER: {what} `{t}` is not a number")))
        };
        let n = number(0, "beam count")?;
        if n != BEAMS as f64 {
            return Err(LineError::new(line, format!("FLASER: expected {BEAMS} beams, found {n}")));
        }
        let ranges_m = (0..BEAMS).map(|b| number(1 + b, "range")).collect::<Result<Vec<_>, _>>()?;
        let base = 1 + BEAMS;
        let pose = Pose2::new(number(base, "x")?, number(base + 1, "y")?, number(base + 2, "θ")?);
        if !pose.is_finite() {
            return Err(LineError::new(line, "FLASER: the pose is not finite"));
        }
        let time_s = number(base + 6, "ipc timestamp")?;
        out.push(LaserRecord { line, ranges_m, pose, time_s });
    }
    Ok(out)
}

/// The beams of a `FLASER 180` scan.
pub fn geometry(max_range_m: f64) -> LaserGeometry {
    LaserGeometry {
        angle_min_rad: -std::f64::consts::FRAC_PI_2,
        angle_increment_rad: 1f64.to_radians(),
        beams: BEAMS,
        max_range_m,
    }
}

/// Builds the world of scans `first_scan .. first_scan + scans` (see the module doc).
pub fn assemble(
    records: &[LaserRecord],
    first_scan: usize,
    scans: usize,
    max_range_m: f64,
) -> Result<World, String> {
    let end = if scans == 0 { records.len() } else { (first_scan + scans).min(records.len()) };
    if end < first_scan + 2 {
        return Err(format!(
            "the window of scans {first_scan}.. holds fewer than two scans (the log has {})",
            records.len()
        ));
    }
    let window = &records[first_scan..end];
    let truth: Vec<Pose2> = window.iter().map(|r| r.pose).collect();
    let odometry: Vec<Pose2> = truth.windows(2).map(|w| w[1].relative_to(w[0])).collect();
    let mut periods: Vec<f64> = window.windows(2).map(|w| w[1].time_s - w[0].time_s).collect();
    periods.sort_by(f64::total_cmp);
    let dt_s = periods[periods.len() / 2];
    let scans = window
        .iter()
        .enumerate()
        .map(|(k, r)| Scan {
            step: k,
            ranges_m: r
                .ranges_m
                .iter()
                .map(|&z| (z.is_finite() && z > 0.0 && z < max_range_m).then_some(z))
                .collect(),
        })
        .collect();
    Ok(World {
        dt_s,
        truth,
        odometry,
        laser: Some(geometry(max_range_m)),
        scans,
        point_scans: Vec::new(),
        truth_lines: Vec::new(),
        truth_corners: Vec::new(),
        truth_points: Vec::new(),
        point_noise: None,
    })
}

/// Reads and assembles the log in `folder`.
pub fn load(
    folder: &Path,
    first_scan: usize,
    scans: usize,
    max_range_m: f64,
) -> Result<World, DatasetError> {
    let path = folder.join(FILE_NAME);
    let records = parse(&read_gz_text(&path)?).map_err(|e| e.in_file(&path))?;
    assemble(&records, first_scan, scans, max_range_m)
        .map_err(|message| DatasetError::Empty { path, message })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(x: f64, t: f64) -> String {
        let ranges: Vec<String> = (0..BEAMS)
            .map(
                |b| if b == 5 { "81.83".to_string() } else { format!("{}", 1.0 + b as f64 * 0.01) },
            )
            .collect();
        format!("FLASER 180 {} {x} 0 0.1 {x} 0 0.1 {t} pippo {t}", ranges.join(" "))
    }

    #[test]
    fn parses_flaser_and_skips_other_messages() {
        let text = format!(
            "# comment\nPARAM a b\nODOM 0 0 0 0 0 0 1 pippo 1\n{}\nNEFF 1\n{}\n{}\n",
            line(0.0, 1.0),
            line(0.5, 3.0),
            line(1.0, 4.0)
        );
        let records = parse(&text).unwrap();
        assert_eq!(records.len(), 3);
        assert_eq!(records[1].line, 6);
        assert_eq!(records[1].pose, Pose2::new(0.5, 0.0, 0.1));
        let world = assemble(&records, 0, 0, DEFAULT_MAX_RANGE_M).unwrap();
        assert_eq!(world.truth.len(), 3);
        assert_eq!(world.odometry.len(), 2);
        // increments are exact: composing them gives the corrected poses back
        let p = world.truth[0].compose(world.odometry[0]).compose(world.odometry[1]);
        assert!(p.position().distance(world.truth[2].position()) < 1e-12);
        assert_eq!(world.scans[0].ranges_m[5], None, "81.83 m is no return");
        assert_eq!(world.scans[0].ranges_m[6], Some(1.06));
        assert_eq!(world.dt_s, 2.0);
        assert!(assemble(&records, 2, 0, 40.0).is_err());
    }

    #[test]
    fn malformed_lines_are_named() {
        let err = parse("FLASER 181 1 2\n").unwrap_err();
        assert_eq!(err.line, 1);
        let bad = line(0.0, 1.0).replace(" 1.1 ", " x ");
        let err = parse(&format!("\n{bad}\n")).unwrap_err();
        assert_eq!(err.line, 2);
        assert!(err.message.contains("`x`"), "{}", err.message);
        let err = parse("FLASER 180 1 2 3\n").unwrap_err();
        assert!(err.message.contains("missing"), "{}", err.message);
    }

    #[test]
    fn real_log_reads_when_present() {
        if !super::super::test_data::available(
            "intel-lab",
            "intel_lab::real_log_reads_when_present",
        ) {
            return;
        }
        let folder = super::super::test_data::repository_root().join("../shared/data/intel-lab");
        let world = load(&folder, 0, 0, DEFAULT_MAX_RANGE_M).unwrap();
        assert_eq!(world.scans.len(), 910);
        let mean_step: f64 = world
            .odometry
            .iter()
            .map(|d| d.position().distance(crate::geom::Point2::new(0.0, 0.0)))
            .sum::<f64>()
            / 909.0;
        assert!((0.4..0.7).contains(&mean_step), "mean step {mean_step} m (README: 0.55 m)");
    }
}
