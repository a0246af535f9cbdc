//! Segment maps: TOML text → [`Map`] (walls, start pose, waypoint trajectory, point landmarks) and
//! the ground-truth landmark list derived from the wall geometry — unique infinite lines (ρ, θ) and
//! corners (x, y), as [FT] §3.2 lists them. Pure: the caller reads the file.

use crate::geom::{Line, Point2, Pose2, Segment};
use crate::source::{Locator, SourceError};
use serde::{Deserialize, Serialize};

/// Two points closer than this [m] are the same vertex; two lines whose ρ differ by less are
/// the same line. Map coordinates are exact decimals, so any tolerance far below 1 mm works.
const GEOMETRY_EPS_M: f64 = 1e-9;
/// Two directions whose angle differs by less than this [rad] are parallel (no corner).
const PARALLEL_EPS_RAD: f64 = 1e-9;
/// Coarsest bitmap scale accepted [m/px] (a metre per pixel is no longer a drawing of walls).
const MAX_BITMAP_M_PER_PX: f64 = 1.0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    name: String,
    title: String,
    #[serde(default)]
    description: String,
    #[serde(default)]
    source: String,
    /// Geometric choices the source leaves open, stated for the report.
    #[serde(default)]
    notes: Vec<String>,
    start: StartPose,
    #[serde(default)]
    walls: Vec<Wall>,
    /// Simulated worlds drive this path; datasets have none.
    trajectory: Option<TrajectorySpec>,
    /// A real dataset instead of a simulation: read by `crate::scenario`, which knows the
    /// loaders; here only whether there is one.
    dataset: Option<toml::Table>,
    /// Point landmarks [[x, y], …] [m] for range-bearing worlds.
    #[serde(default)]
    landmarks: Vec<[f64; 2]>,
    /// Scale [m/px] of the bitmap the source drew the map as (e.g. [FT] §10.3.1: 1.8 or 3.2 cm/px),
    /// for walls given in pixels (`laser.wall_thickness_px`).
    bitmap_m_per_px: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StartPose {
    x_m: f64,
    y_m: f64,
    theta_deg: f64,
}

/// A wall as a polyline through `points` [[x, y], …] [m]; close a room by repeating the first point.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Wall {
    points: Vec<[f64; 2]>,
}

/// The scripted path: waypoints visited in order, the whole list driven `laps` times.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    /// Speed limit [m/s] ([FT] §3.2: ≤ 0.5 m/s).
    pub max_speed_mps: f64,
    /// Turn-rate limit [deg/s].
    #[serde(default = "default_turn_rate")]
    pub max_turn_rate_dps: f64,
    /// How many times the waypoint list is driven ([FT]: loops driven twice).
    pub laps: u32,
    /// A waypoint counts as reached within this distance [m].
    #[serde(default = "default_tolerance")]
    pub waypoint_tolerance_m: f64,
    /// Waypoints [[x, y], …] [m] of one lap.
    pub waypoints: Vec<[f64; 2]>,
}

fn default_turn_rate() -> f64 {
    45.0
}
fn default_tolerance() -> f64 {
    0.2
}

/// A validated map with its derived ground-truth landmarks.
#[derive(Debug, Clone, PartialEq)]
pub struct Map {
    pub name: String,
    pub title: String,
    pub description: String,
    pub source: String,
    pub notes: Vec<String>,
    pub start: Pose2,
    pub walls: Vec<Segment>,
    /// The driven path of a simulated world (`None` for a dataset).
    pub trajectory: Option<TrajectorySpec>,
    pub point_landmarks: Vec<Point2>,
    /// Scale [m/px] of the source's bitmap, when the source drew the map as one.
    pub bitmap_m_per_px: Option<f64>,
    /// Unique infinite lines through the walls, in order of first appearance.
    pub lines: Vec<Line>,
    /// Vertices where two non-parallel walls meet, in order of first appearance.
    pub corners: Vec<Point2>,
}

impl Map {
    /// Parses and validates a map file's text.
    pub fn from_toml(text: &str) -> Result<Map, Vec<SourceError>> {
        let loc = Locator::new(text);
        let file: MapFile =
            toml::from_str(text).map_err(|e| vec![SourceError::from_toml(&loc, &e)])?;
        let mut errors = Vec::new();
        let mut err = |key: &str, msg: String| errors.push(SourceError::at_key(&loc, key, msg));

        // Map names become file names and parts of run ids.
        if file.name.is_empty()
            || !file
                .name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '-')
        {
            err(
                "name",
                format!(
                    "must be non-empty lower-case letters, digits, `-` or `_`, got {:?}",
                    file.name
                ),
            );
        }
        let mut walls = Vec::new();
        for (i, wall) in file.walls.iter().enumerate() {
            if wall.points.len() < 2 {
                err(&format!("walls[{i}].points"), "a wall needs at least two points".into());
            }
            for (j, pair) in wall.points.windows(2).enumerate() {
                let s = Segment::new(
                    Point2::new(pair[0][0], pair[0][1]),
                    Point2::new(pair[1][0], pair[1][1]),
                );
                let finite = pair.iter().flatten().all(|v| v.is_finite());
                // (a point that is not a number is named as such below, not as a repeat)
                if finite && !(s.length() > GEOMETRY_EPS_M) {
                    err(
                        &format!("walls[{i}].points[{}]", j + 1),
                        "repeats the previous point (zero-length wall)".into(),
                    );
                } else {
                    walls.push(s);
                }
            }
        }
        match (&file.trajectory, &file.dataset) {
            (Some(_), Some(_)) => {
                return Err(vec![SourceError::at_key(
                    &loc,
                    "dataset",
                    "a map has either a [trajectory] (simulation) or a [dataset] (real data), not both",
                )]);
            }
            (None, None) => {
                return Err(vec![SourceError::at_key(
                    &loc,
                    "",
                    "missing [trajectory] (or [dataset] for real data)",
                )]);
            }
            _ => {}
        }
        if let Some(t) = &file.trajectory {
            if !(t.max_speed_mps > 0.0 && t.max_speed_mps.is_finite()) {
                err("trajectory.max_speed_mps", format!("must be > 0, got {}", t.max_speed_mps));
            }
            if !(t.max_turn_rate_dps > 0.0 && t.max_turn_rate_dps.is_finite()) {
                err(
                    "trajectory.max_turn_rate_dps",
                    format!("must be > 0, got {}", t.max_turn_rate_dps),
                );
            }
            if t.laps == 0 {
                err("trajectory.laps", "must be ≥ 1".into());
            }
            if !(t.waypoint_tolerance_m > 0.0 && t.waypoint_tolerance_m.is_finite()) {
                err(
                    "trajectory.waypoint_tolerance_m",
                    format!("must be > 0, got {}", t.waypoint_tolerance_m),
                );
            }
            if t.waypoints.is_empty() {
                err("trajectory.waypoints", "needs at least one waypoint".into());
            }
        }
        if let Some(s) = file.bitmap_m_per_px {
            if !(s > 0.0 && s <= MAX_BITMAP_M_PER_PX) {
                err(
                    "bitmap_m_per_px",
                    format!("must be in (0, {MAX_BITMAP_M_PER_PX}] m per pixel, got {s}"),
                );
            }
        }
        // every coordinate finite, each bad one named by its key
        let finite = |p: &[f64; 2]| p.iter().all(|v| v.is_finite());
        for (i, w) in file.walls.iter().enumerate() {
            for (j, p) in w.points.iter().enumerate().filter(|(_, p)| !finite(p)) {
                err(
                    &format!("walls[{i}].points[{j}]"),
                    format!("coordinates must be finite numbers, got [{}, {}]", p[0], p[1]),
                );
            }
        }
        for (k, p) in file
            .trajectory
            .iter()
            .flat_map(|t| t.waypoints.iter().enumerate())
            .filter(|(_, p)| !finite(p))
        {
            err(
                &format!("trajectory.waypoints[{k}]"),
                format!("coordinates must be finite numbers, got [{}, {}]", p[0], p[1]),
            );
        }
        for (k, p) in file.landmarks.iter().enumerate().filter(|(_, p)| !finite(p)) {
            err(
                &format!("landmarks[{k}]"),
                format!("coordinates must be finite numbers, got [{}, {}]", p[0], p[1]),
            );
        }
        for (key, v) in [
            ("start.x_m", file.start.x_m),
            ("start.y_m", file.start.y_m),
            ("start.theta_deg", file.start.theta_deg),
        ] {
            if !v.is_finite() {
                err(key, format!("must be a finite number, got {v}"));
            }
        }
        let all_finite = file.walls.iter().all(|w| w.points.iter().all(finite))
            && file.trajectory.iter().all(|t| t.waypoints.iter().all(finite))
            && file.start.x_m.is_finite()
            && file.start.y_m.is_finite();
        // The scripted path (start → waypoints, then around again for further laps) must not
        // pass through a wall: a robot driven through one would see the world from inside it.
        if let (Some(t), true) = (&file.trajectory, all_finite) {
            let start = Point2::new(file.start.x_m, file.start.y_m);
            let points: Vec<Point2> = t.waypoints.iter().map(|p| Point2::new(p[0], p[1])).collect();
            let mut legs: Vec<(String, Point2, Point2)> = Vec::new();
            if let Some(&first) = points.first() {
                legs.push(("the start".into(), start, first));
            }
            for k in 1..points.len() {
                legs.push((format!("waypoint {}", k - 1), points[k - 1], points[k]));
            }
            if t.laps > 1 && points.len() > 1 {
                legs.push((
                    format!("waypoint {} (the next lap)", points.len() - 1),
                    points[points.len() - 1],
                    points[0],
                ));
            }
            for (k, (from, a, b)) in legs.iter().enumerate() {
                let length = a.distance(*b);
                if length <= GEOMETRY_EPS_M {
                    continue;
                }
                let (c, s) = ((b.x - a.x) / length, (b.y - a.y) / length);
                if let Some(wall) = walls.iter().find(|w| {
                    w.ray_intersection(*a, c, s)
                        .is_some_and(|d| d > GEOMETRY_EPS_M && d < length - GEOMETRY_EPS_M)
                }) {
                    let key = if k == 0 {
                        "start".to_string()
                    } else {
                        format!("trajectory.waypoints[{}]", (k).min(points.len() - 1))
                    };
                    err(
                        &key,
                        format!(
                            "the path from {from} ({}, {}) to ({}, {}) crosses the wall from ({}, {}) to ({}, {})",
                            a.x, a.y, b.x, b.y, wall.a.x, wall.a.y, wall.b.x, wall.b.y
                        ),
                    );
                }
            }
        }
        if !errors.is_empty() {
            return Err(errors);
        }
        let (lines, corners) = derive_landmarks(&walls);
        Ok(Map {
            name: file.name,
            title: file.title,
            description: file.description,
            source: file.source,
            notes: file.notes,
            start: Pose2::new(file.start.x_m, file.start.y_m, file.start.theta_deg.to_radians()),
            walls,
            trajectory: file.trajectory,
            point_landmarks: file.landmarks.iter().map(|p| Point2::new(p[0], p[1])).collect(),
            bitmap_m_per_px: file.bitmap_m_per_px,
            lines,
            corners,
        })
    }

    /// Point-landmark world (point landmarks) or laser world (walls only). A dataset's kind is
    /// its loader's: [`crate::scenario::Scenario::world_kind`].
    pub fn world_kind(&self) -> crate::world::WorldKind {
        if self.point_landmarks.is_empty() {
            crate::world::WorldKind::Laser
        } else {
            crate::world::WorldKind::Points
        }
    }

    /// Number of ground-truth landmarks of the laser world (lines + corners).
    pub fn landmark_count(&self) -> usize {
        self.lines.len() + self.corners.len()
    }
}

/// Ground-truth landmarks from wall geometry ([FT] §3.2):
/// - one infinite line per set of collinear walls (the reference lists each line once, e.g.
///   Complex's y = 9 and x = 36 bound two walls each);
/// - a corner wherever two non-parallel walls touch (shared end point, or an end point on the
///   other wall — a T-junction). Free wall ends are not corners (Lineamedia's interior wall).
pub fn derive_landmarks(walls: &[Segment]) -> (Vec<Line>, Vec<Point2>) {
    let mut lines: Vec<Line> = Vec::new();
    for w in walls {
        let l = w.line();
        if !lines.iter().any(|m| m.coincides(&l, GEOMETRY_EPS_M, PARALLEL_EPS_RAD)) {
            lines.push(l);
        }
    }
    let mut corners: Vec<Point2> = Vec::new();
    for (i, a) in walls.iter().enumerate() {
        for b in &walls[i + 1..] {
            let (ax, ay) = a.direction();
            let (bx, by) = b.direction();
            if (ax * by - ay * bx).abs() < PARALLEL_EPS_RAD.sin() {
                continue;
            }
            let touching =
                [a.a, a.b].into_iter().find(|&p| b.distance_to_point(p) < GEOMETRY_EPS_M).or_else(
                    || [b.a, b.b].into_iter().find(|&p| a.distance_to_point(p) < GEOMETRY_EPS_M),
                );
            if let Some(p) = touching
                && !corners.iter().any(|c| c.distance(p) < GEOMETRY_EPS_M)
            {
                corners.push(p);
            }
        }
    }
    (lines, corners)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOX: &str = r#"
name = "box"
title = "Box"
start = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }
[[walls]]
points = [[-1, -1], [19, -1], [19, 9], [-1, 9], [-1, -1]]
[[walls]]
points = [[2, 4], [16, 4]]
[trajectory]
max_speed_mps = 0.5
laps = 2
waypoints = [[18, 0], [0, 0]]
"#;

    #[test]
    fn free_standing_wall_adds_a_line_but_no_corner() {
        let m = Map::from_toml(BOX).unwrap();
        assert_eq!(m.lines.len(), 5);
        assert_eq!(m.corners.len(), 4);
        assert_eq!(m.walls.len(), 5);
    }

    #[test]
    fn t_junction_is_a_corner() {
        let walls = [
            Segment::new(Point2::new(0.0, 0.0), Point2::new(10.0, 0.0)),
            Segment::new(Point2::new(5.0, 0.0), Point2::new(5.0, 3.0)),
        ];
        let (lines, corners) = derive_landmarks(&walls);
        assert_eq!(lines.len(), 2);
        assert_eq!(corners, vec![Point2::new(5.0, 0.0)]);
    }

    #[test]
    fn collinear_walls_share_one_line_and_make_no_corner() {
        let walls = [
            Segment::new(Point2::new(0.0, 9.0), Point2::new(5.0, 9.0)),
            Segment::new(Point2::new(5.0, 9.0), Point2::new(8.0, 9.0)),
            Segment::new(Point2::new(12.0, 9.0), Point2::new(10.0, 9.0)),
        ];
        let (lines, corners) = derive_landmarks(&walls);
        assert_eq!(lines.len(), 1);
        assert!(corners.is_empty());
    }

    #[test]
    fn errors_name_line_and_key() {
        let bad = BOX
            .replace("laps = 2", "laps = 0")
            .replace("max_speed_mps = 0.5", "max_speed_mps = -1.0");
        let errs = Map::from_toml(&bad).unwrap_err();
        let keys: Vec<_> = errs.iter().map(|e| (e.key.as_str(), e.line)).collect();
        assert_eq!(keys, vec![("trajectory.max_speed_mps", 10), ("trajectory.laps", 11)]);
    }

    #[test]
    fn a_path_through_a_wall_is_an_error_naming_the_waypoint() {
        // the leg from (0, 0) up to (10, 6) crosses the free-standing wall y = 4
        let bad =
            BOX.replace("waypoints = [[18, 0], [0, 0]]", "waypoints = [[18, 0], [0, 0], [10, 6]]");
        let errs = Map::from_toml(&bad).unwrap_err();
        // (and so does the next lap's leg back from (10, 6) to (18, 0))
        assert_eq!(errs.len(), 2, "{errs:?}");
        assert_eq!((errs[0].key.as_str(), errs[0].line), ("trajectory.waypoints[2]", 12));
        assert!(
            errs[0].message.contains(
                "from waypoint 1 (0, 0) to (10, 6) crosses the wall from (2, 4) to (16, 4)"
            ),
            "{}",
            errs[0].message
        );
        // a start outside the room: its leg to the first waypoint crosses the outer wall
        let outside =
            BOX.replace("start = { x_m = 0.0, y_m = 0.0", "start = { x_m = -5.0, y_m = 0.0");
        let errs = Map::from_toml(&outside).unwrap_err();
        assert_eq!(errs[0].key, "start");
        assert!(errs[0].message.contains("the path from the start (-5, 0)"), "{}", errs[0].message);
        // the next lap's leg (last waypoint → first) is checked too
        let wrap =
            BOX.replace("waypoints = [[18, 0], [0, 0]]", "waypoints = [[18, 0], [0, 0], [0, 6]]");
        assert!(Map::from_toml(&wrap).unwrap_err()[0].message.contains("(the next lap)"));
        // touching a wall's end is not crossing it
        assert!(
            Map::from_toml(
                &BOX.replace(
                    "waypoints = [[18, 0], [0, 0]]",
                    "waypoints = [[18, 0], [2, 4], [0, 0]]"
                )
            )
            .is_ok()
        );
    }

    #[test]
    fn a_non_finite_coordinate_is_named_by_its_key() {
        let bad = BOX.replace("waypoints = [[18, 0], [0, 0]]", "waypoints = [[18, 0], [nan, 0]]");
        let errs = Map::from_toml(&bad).unwrap_err();
        assert_eq!((errs[0].key.as_str(), errs[0].line), ("trajectory.waypoints[1]", 12));
        assert!(errs[0].message.contains("finite"), "{}", errs[0].message);
        let bad = BOX.replace("[19, 9], [-1, 9]", "[19, inf], [-1, 9]");
        assert_eq!(Map::from_toml(&bad).unwrap_err()[0].key, "walls[0].points[2]");
        // a NaN is not a repeated point: one error, that it is not a number
        let bad = BOX.replace("[19, 9], [-1, 9]", "[19, nan], [-1, 9]");
        let errs = Map::from_toml(&bad).unwrap_err();
        assert_eq!(errs.len(), 1, "{errs:?}");
        assert!(errs[0].message.contains("finite"), "{}", errs[0].message);
    }

    #[test]
    fn unknown_key_is_rejected_with_its_line() {
        let bad = BOX.replace("laps = 2", "laps = 2\nspeed = 3");
        let errs = Map::from_toml(&bad).unwrap_err();
        assert_eq!(errs.len(), 1);
        assert!(errs[0].message.contains("unknown field `speed`"), "{}", errs[0].message);
        assert_eq!(errs[0].line, 12);
    }
}
