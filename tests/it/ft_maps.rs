//! The five [FT] maps: landmark lists derived from our wall geometry must equal the lists the
//! thesis publishes ([FT] §3.2, Table 10.1, transcribed in ../shared/reference/fastslam-thesis.md),
//! and the scripted trajectories must meet the thesis's description.

use crate::util::repo;
use slamlab::geom::{Point2, wrap_angle};
use slamlab::world::map::Map;
use slamlab::world::trajectory;

/// (ρ [m], θ [deg]) lines and (x, y) corners as printed in [FT] §3.2.
struct Reference {
    name: &'static str,
    lines: &'static [(f64, f64)],
    corners: &'static [(f64, f64)],
}

const OUTER_LINES: [(f64, f64); 4] = [(1.0, -90.0), (9.0, 90.0), (1.0, 180.0), (19.0, 0.0)];
const OUTER_CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (-1.0, 9.0), (19.0, -1.0), (19.0, 9.0)];

const FT: &[Reference] = &[
    Reference { name: "recinto_basico", lines: &OUTER_LINES, corners: &OUTER_CORNERS },
    Reference {
        name: "lineamedia",
        lines: &[(1.0, -90.0), (9.0, 90.0), (1.0, 180.0), (19.0, 0.0), (4.0, 90.0)],
        corners: &OUTER_CORNERS,
    },
    Reference {
        name: "bigloop",
        lines: &[
            (1.0, -90.0),
            (9.0, 90.0),
            (1.0, 180.0),
            (19.0, 0.0),
            (2.0, 90.0),
            (6.0, 90.0),
            (2.0, 0.0),
            (16.0, 0.0),
        ],
        corners: &[
            (-1.0, -1.0),
            (19.0, -1.0),
            (19.0, 9.0),
            (-1.0, 9.0),
            (2.0, 2.0),
            (16.0, 2.0),
            (16.0, 6.0),
            (2.0, 6.0),
        ],
    },
    Reference {
        name: "bigloop2",
        lines: &[
            (1.0, -90.0),
            (9.0, 90.0),
            (1.0, 180.0),
            (19.0, 0.0),
            (2.0, 90.0),
            (6.0, 90.0),
            (2.0, 0.0),
            (16.0, 0.0),
            (10.0, 0.0),
            (8.0, 0.0),
        ],
        corners: &[
            (-1.0, -1.0),
            (19.0, -1.0),
            (19.0, 9.0),
            (-1.0, 9.0),
            (2.0, 2.0),
            (16.0, 2.0),
            (16.0, 6.0),
            (2.0, 6.0),
            (8.0, 2.0),
            (8.0, 6.0),
            (10.0, 2.0),
            (10.0, 6.0),
        ],
    },
    Reference {
        name: "complex",
        lines: &[
            (1.0, -90.0),
            (1.0, 180.0),
            (9.0, 90.0),
            (19.0, 0.0),
            (19.0, 90.0),
            (39.0, 0.0),
            (2.0, 0.0),
            (36.0, 0.0),
            (2.0, 90.0),
            (6.0, 90.0),
            (22.0, 0.0),
            (16.0, 90.0),
        ],
        corners: &[
            (-1.0, -1.0),
            (-1.0, 9.0),
            (19.0, 9.0),
            (19.0, 19.0),
            (39.0, 19.0),
            (39.0, -1.0),
            (2.0, 2.0),
            (2.0, 6.0),
            (36.0, 2.0),
            (22.0, 9.0),
            (22.0, 16.0),
            (36.0, 6.0),
            (36.0, 16.0),
            (36.0, 9.0),
        ],
    },
];

fn load(name: &str) -> Map {
    let text = std::fs::read_to_string(repo().join(format!("data/maps/{name}.toml"))).unwrap();
    Map::from_toml(&text).unwrap_or_else(|e| panic!("{name}: {e:?}"))
}

#[test]
fn derived_landmarks_match_the_thesis_lists() {
    for r in FT {
        let m = load(r.name);
        assert_eq!(m.lines.len(), r.lines.len(), "{}: line count", r.name);
        assert_eq!(m.corners.len(), r.corners.len(), "{}: corner count", r.name);
        for &(rho, theta_deg) in r.lines {
            let found = m.lines.iter().any(|l| {
                (l.rho - rho).abs() < 1e-9
                    && wrap_angle(l.theta - theta_deg.to_radians()).abs() < 1e-9
            });
            assert!(
                found,
                "{}: line (ρ = {rho}, θ = {theta_deg}°) not derived; got {:?}",
                r.name, m.lines
            );
        }
        for &(x, y) in r.corners {
            assert!(
                m.corners.iter().any(|c| c.distance(Point2::new(x, y)) < 1e-9),
                "{}: corner ({x}, {y}) not derived",
                r.name
            );
        }
    }
}

#[test]
fn landmark_totals_are_8_9_16_22_26() {
    let totals: Vec<usize> = FT.iter().map(|r| load(r.name).landmark_count()).collect();
    assert_eq!(totals, [8, 9, 16, 22, 26]);
}

#[test]
fn trajectories_follow_the_thesis_description() {
    // [FT] §3.2: loops driven twice, ≤ 0.5 m/s, longer than 200 m, start at (0, 0, 0°).
    for r in FT {
        let m = load(r.name);
        let path = m.trajectory.as_ref().expect("a simulated map has a trajectory");
        assert_eq!(path.laps, 2, "{}", r.name);
        assert_eq!((m.start.x, m.start.y, m.start.theta), (0.0, 0.0, 0.0), "{}", r.name);
        let run = trajectory::drive(m.start, path, 0.1).unwrap();
        let length: f64 =
            run.poses.windows(2).map(|w| w[0].position().distance(w[1].position())).sum();
        assert!(length > 200.0, "{}: {length} m", r.name);
        assert!(run.controls.iter().all(|&(v, _)| v <= 0.5 + 1e-12), "{}", r.name);
        // the path keeps clear of every wall (robot radius + margin)
        let clearance = run
            .poses
            .iter()
            .map(|p| {
                m.walls
                    .iter()
                    .map(|w| w.distance_to_point(p.position()))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(clearance > 0.5, "{}: comes within {clearance} m of a wall", r.name);
    }
}
