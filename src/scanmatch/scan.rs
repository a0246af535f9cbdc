//! A prepared polar scan: raw ranges (`&[Option<f64>]`, `None` = no return) → [`PolarScan`]
//! (filtered ranges, validity, segment labels), the one input every matcher reads ([EP] §3–5.2,
//! Diosi's PSM `PMScan`).
//!
//! Preprocessing proper (Diosi's heuristics, line segmentation) lives in [`super::segment`]; this
//! file only holds the data type, the plain "contiguous runs" labelling that `segment`'s `none`
//! method and the tests use, and [`testing`]: ideal scans cast from wall segments.

/// A scan ready for matching. Beam `i` has bearing `angle_min_rad + i·angle_increment_rad`
/// (laser frame: x forward, bearings counter-clockwise; a 180° scan spans [−π/2, π/2]).
#[derive(Debug, Clone, PartialEq)]
pub struct PolarScan {
    /// Bearing of beam 0 [rad].
    pub angle_min_rad: f64,
    /// Bearing step between consecutive beams [rad] (> 0).
    pub angle_increment_rad: f64,
    /// Ranges [m] after filtering (median / line projection); meaningful only where `valid`.
    pub ranges: Vec<f64>,
    /// Whether the beam may be used at all (as a reference range, or as an interpolation node).
    pub valid: Vec<bool>,
    /// Segment label per beam; 0 = in no segment: never used as an interpolation node ([EP] §5.2:
    /// interpolation only between points of the same segment).
    pub segment: Vec<u32>,
}

impl PolarScan {
    /// Bearing of beam `i` [rad].
    #[inline]
    pub fn bearing(&self, i: usize) -> f64 {
        self.angle_min_rad + i as f64 * self.angle_increment_rad
    }

    /// Number of beams.
    pub fn len(&self) -> usize {
        self.ranges.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// Number of valid beams.
    pub fn valid_count(&self) -> usize {
        self.valid.iter().filter(|&&v| v).count()
    }

    /// Number of distinct non-zero segment labels.
    pub fn segment_count(&self) -> usize {
        let mut labels: Vec<u32> = self.segment.iter().copied().filter(|&s| s != 0).collect();
        labels.sort_unstable();
        labels.dedup();
        labels.len()
    }

    /// Whether `other` has the same beam geometry (count, first bearing, step), which PSM's
    /// array-shift orientation search needs. Bearings are compared to 1e-9 rad.
    pub fn same_geometry(&self, other: &PolarScan) -> bool {
        const BEARING_TOL_RAD: f64 = 1e-9;
        self.len() == other.len()
            && (self.angle_min_rad - other.angle_min_rad).abs() <= BEARING_TOL_RAD
            && (self.angle_increment_rad - other.angle_increment_rad).abs() <= BEARING_TOL_RAD
    }

    /// Whether the struct is internally consistent (equal lengths, finite positive step, finite
    /// ranges on valid beams). Matchers treat an inconsistent scan as having no valid beams.
    pub fn is_consistent(&self) -> bool {
        self.valid.len() == self.ranges.len()
            && self.segment.len() == self.ranges.len()
            && self.angle_min_rad.is_finite()
            && self.angle_increment_rad.is_finite()
            && self.angle_increment_rad > 0.0
            && self.ranges.iter().zip(&self.valid).all(|(r, &v)| !v || (r.is_finite() && *r > 0.0))
    }

    /// Raw ranges, no filtering. A reading is valid when it is `Some`, finite, > 0 and
    /// ≤ `max_range_m`. Segments are the maximal runs of consecutive valid readings whose range
    /// changes by at most `max_jump_m` from one beam to the next (`f64::INFINITY`: no jump test, the
    /// `none` segmentation); a run of a single reading stays valid but gets segment 0.
    pub fn contiguous(
        ranges: &[Option<f64>],
        angle_min_rad: f64,
        angle_increment_rad: f64,
        max_range_m: f64,
        max_jump_m: f64,
    ) -> PolarScan {
        let n = ranges.len();
        let mut scan = PolarScan {
            angle_min_rad,
            angle_increment_rad,
            ranges: vec![0.0; n],
            valid: vec![false; n],
            segment: vec![0; n],
        };
        for (i, r) in ranges.iter().enumerate() {
            if let Some(r) = *r
                && usable_range(r, max_range_m)
            {
                scan.ranges[i] = r;
                scan.valid[i] = true;
            }
        }
        let mut label = 0u32;
        let mut run_start = 0usize;
        for i in 0..=n {
            let continues = i < n
                && i > run_start
                && scan.valid[i]
                && scan.valid[i - 1]
                && (scan.ranges[i] - scan.ranges[i - 1]).abs() <= max_jump_m;
            if continues {
                continue;
            }
            // close the run [run_start, i)
            if i >= run_start + 2 && scan.valid[run_start] {
                label += 1;
                scan.segment[run_start..i].fill(label);
            }
            run_start = i;
        }
        scan
    }
}

/// A raw reading is usable when finite, positive and within the sensor's maximum range.
#[inline]
pub(crate) fn usable_range(r: f64, max_range_m: f64) -> bool {
    r.is_finite() && r > 0.0 && r <= max_range_m
}

/// Ideal (noise-free) scans cast from wall segments, scene builders and a proportional range-noise
/// model, for tests and benches. Pure: randomness only through the caller's RNG.
pub mod testing {
    use super::PolarScan;
    use crate::geom::{Point2, Pose2, Segment, cast_ray};
    use rand::Rng;
    use rand_distr::{Distribution, StandardNormal};
    use std::f64::consts::FRAC_PI_2;

    /// Beam geometry of a scanner.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct Beams {
        pub angle_min_rad: f64,
        pub angle_increment_rad: f64,
        pub count: usize,
    }

    impl Beams {
        /// SICK LMS200-like: 181 beams at 1° over [−90°, 90°] (PSM's default; [EP] §4 assumption).
        pub fn lms200() -> Beams {
            Beams { angle_min_rad: -FRAC_PI_2, angle_increment_rad: 1f64.to_radians(), count: 181 }
        }

        pub fn bearing(&self, i: usize) -> f64 {
            self.angle_min_rad + i as f64 * self.angle_increment_rad
        }
    }

    /// Max range of the test scanner [m] (PSM's PM_MAX_RANGE = 1000 cm).
    pub const MAX_RANGE_M: f64 = 10.0;

    /// Range-jump threshold [m] used by [`room_pair`]'s labelling (PSM's PM_SEG_MAX_DIST = 20 cm).
    pub const JUMP_M: f64 = 0.2;

    /// An ideal scan: each beam returns the nearest wall hit within `max_range_m`, else `None`.
    pub fn cast_scan(
        walls: &[Segment],
        pose: Pose2,
        beams: &Beams,
        max_range_m: f64,
    ) -> Vec<Option<f64>> {
        (0..beams.count)
            .map(|i| cast_ray(walls, pose.position(), pose.theta + beams.bearing(i), max_range_m))
            .collect()
    }

    /// Closed polygon → wall segments.
    pub fn polygon(vertices: &[(f64, f64)]) -> Vec<Segment> {
        let n = vertices.len();
        (0..n)
            .map(|k| {
                let (ax, ay) = vertices[k];
                let (bx, by) = vertices[(k + 1) % n];
                Segment::new(Point2::new(ax, ay), Point2::new(bx, by))
            })
            .collect()
    }

    /// [EP] Fig 8 stand-in: a 10 m × 5 m rectangular room, corners (0, 0)–(10, 5), with a
    /// 0.5 m square column spanning (5.0, 2.2)–(5.5, 2.7). Seen from [`ROOM_REFERENCE_POSE`] the
    /// column hides part of the far wall (occlusions, range jumps).
    pub fn rect_room_with_column() -> Vec<Segment> {
        let mut walls = polygon(&[(0.0, 0.0), (10.0, 0.0), (10.0, 5.0), (0.0, 5.0)]);
        walls.extend(polygon(&[(5.0, 2.2), (5.5, 2.2), (5.5, 2.7), (5.0, 2.7)]));
        walls
    }

    /// A laser pose inside [`rect_room_with_column`] looking along +x at the column.
    pub const ROOM_REFERENCE_POSE: Pose2 = Pose2::new(2.0, 2.5, 0.0);

    /// [EP] Fig 9 stand-in: a non-convex 10-vertex polygon (about 9 m × 6 m).
    pub fn polygon_room() -> Vec<Segment> {
        polygon(&[
            (0.0, 0.0),
            (6.0, 0.0),
            (7.0, 1.5),
            (9.0, 1.5),
            (9.0, 5.0),
            (6.5, 6.0),
            (4.0, 4.5),
            (2.5, 6.0),
            (0.0, 5.0),
            (0.8, 2.5),
        ])
    }

    /// A laser pose inside [`polygon_room`].
    pub const POLYGON_REFERENCE_POSE: Pose2 = Pose2::new(2.5, 2.5, 0.2);

    /// Proportional range noise ([EP] Table 1, "σ when the measure is 1 m"):
    /// r ← r + N(0, (σ_1m · r / 1 m)²), independently per beam; `None` stays `None`.
    pub fn add_range_noise<R: Rng + ?Sized>(
        ranges: &[Option<f64>],
        sigma_at_1m_m: f64,
        rng: &mut R,
    ) -> Vec<Option<f64>> {
        ranges
            .iter()
            .map(|r| {
                r.map(|r| {
                    let z: f64 = StandardNormal.sample(rng);
                    r + sigma_at_1m_m * r * z
                })
            })
            .collect()
    }

    /// Raw (noise-free unless noised by the caller) ranges of a reference and a current scan:
    /// the reference laser at `reference_pose` (world), the current one at
    /// `reference_pose ⊕ delta`, so `delta` is the true current pose in the reference frame.
    pub fn raw_pair(
        walls: &[Segment],
        reference_pose: Pose2,
        delta: Pose2,
        beams: &Beams,
    ) -> (Vec<Option<f64>>, Vec<Option<f64>>) {
        let reference = cast_scan(walls, reference_pose, beams, MAX_RANGE_M);
        let current = cast_scan(walls, reference_pose.compose(delta), beams, MAX_RANGE_M);
        (reference, current)
    }

    /// A noise-free (reference, current) pair in [`rect_room_with_column`] with the true current pose
    /// `delta` in the reference frame; LMS200 beams; raw ranges labelled by
    /// [`PolarScan::contiguous`] with a [`JUMP_M`] jump threshold.
    pub fn room_pair(delta: Pose2) -> (PolarScan, PolarScan) {
        let beams = Beams::lms200();
        let (r, c) = raw_pair(&rect_room_with_column(), ROOM_REFERENCE_POSE, delta, &beams);
        let prep = |raw: &[Option<f64>]| {
            PolarScan::contiguous(
                raw,
                beams.angle_min_rad,
                beams.angle_increment_rad,
                MAX_RANGE_M,
                JUMP_M,
            )
        };
        (prep(&r), prep(&c))
    }
}

#[cfg(test)]
mod tests {
    use super::testing::*;
    use super::*;
    use crate::geom::Pose2;

    #[test]
    fn contiguous_labels_runs_and_isolated_points() {
        let raw = [
            Some(1.0),
            Some(1.05),
            Some(1.1),
            None,
            Some(2.0),
            Some(5.0),
            Some(5.1),
            Some(f64::NAN),
            Some(11.0),
        ];
        let s = PolarScan::contiguous(&raw, 0.0, 0.1, 10.0, 0.2);
        assert_eq!(s.valid, [true, true, true, false, true, true, true, false, false]);
        assert_eq!(s.segment, [1, 1, 1, 0, 0, 2, 2, 0, 0]);
        assert_eq!(s.segment_count(), 2);
        assert!(s.is_consistent());
        // no jump test: 2.0 and 5.0 join
        let s = PolarScan::contiguous(&raw, 0.0, 0.1, 10.0, f64::INFINITY);
        assert_eq!(s.segment, [1, 1, 1, 0, 2, 2, 2, 0, 0]);
        // empty input
        assert!(PolarScan::contiguous(&[], 0.0, 0.1, 10.0, 0.2).is_empty());
    }

    #[test]
    fn room_scan_sees_walls_and_column() {
        let beams = Beams::lms200();
        let raw = cast_scan(&rect_room_with_column(), ROOM_REFERENCE_POSE, &beams, MAX_RANGE_M);
        assert_eq!(raw.len(), 181);
        assert!(raw.iter().all(|r| r.is_some()));
        // straight ahead: the column's near face at x = 5.0 → 3.0 m; straight left: y = 5 wall at 2.5 m
        assert!((raw[90].unwrap() - 3.0).abs() < 1e-12);
        assert!((raw[180].unwrap() - 2.5).abs() < 1e-12);
        let (r, c) = room_pair(Pose2::new(0.2, -0.1, 3f64.to_radians()));
        assert!(r.segment_count() >= 2 && c.segment_count() >= 2);
        assert!(r.same_geometry(&c));
    }
}
