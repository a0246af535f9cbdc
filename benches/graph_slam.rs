//! Graph-based SLAM's cost per odometry step against EKF-SLAM's as the map grows from 35 to
//! 1 000 to 10 000 landmarks (issue 28), printed as a Markdown table.
//!
//! The worlds keep the landmark density fixed so that the robot sees about as many landmarks per
//! reading in each: a square route of side s driven once at 1 m/s (odometry at 10 Hz, 10 % noise),
//! N landmarks scattered (seeded) in a band of ±8 m around it — 0.1 landmarks per m², s = N / 6.4 m
//! (the 35-landmark world is a 10 m square) — read at 5 Hz within 8 m, at most 20 per reading,
//! known association.
//!
//! Per case, wall time over the whole run divided by its steps, one run each (these runs take
//! seconds to minutes; criterion's ten samples would take an hour):
//! - `ekf_slam`: the filter, O(n²) per update in the map size n;
//! - `graph_slam_batch`: the smoothed estimate as the registry runs it (warm re-solves every 10
//!   steps to initialise the final one, so O(steps²) over a run);
//! - `graph_slam` (online): re-solved every 10 steps, O(steps²) over a run;
//! - `one solve`: one solve of the whole graph from near its optimum (poses at the truth,
//!   landmarks at their first reading from there; `graph::graph_at_truth`) — the smoother's
//!   building block, what each re-solve costs, O(steps) while the factor stays sparse.
//!
//! Cases that would run for too long are skipped and say why: EKF-SLAM at 10 000 landmarks (a
//! 20 003² covariance of 3.2 GB); the re-solving smoothers beyond 35 landmarks — they re-solve
//! the whole graph every 10 steps, O(steps²) over a run: at 1 000 landmarks (6 250 steps) one
//! of them ran for over 10 minutes.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slamlab::slam::ekf::{self, EkfAssociation, EkfParams};
use slamlab::slam::graph::{self, GraphParams};
use slamlab::slam::motion::MotionModel;
use slamlab::slam::observations::{Source, StepObservations, stream};
use slamlab::world::map::Map;
use slamlab::world::odometry::OdometryNoise;
use slamlab::world::point_sensor::PointSensorParams;
use slamlab::world::{SimParams, World, WorldSpec, generate};
use std::hint::black_box;
use std::time::Instant;

/// N landmarks in a ±8 m band around a square route of side N / 6.4 m (at least 10 m).
fn world(n: usize) -> World {
    let side = (n as f64 / 6.4).max(10.0);
    let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
    let lms: Vec<String> = (0..n)
        .map(|_| {
            // a point of the route, then an offset across it
            let along = rng.random_range(0.0..4.0 * side);
            let across = rng.random_range(-8.0..8.0);
            let (edge, t) = ((along / side) as usize, along % side);
            let (x, y) = match edge {
                0 => (t, across),
                1 => (side + across, t),
                2 => (side - t, side + across),
                _ => (across, side - t),
            };
            format!("[{x:.3}, {y:.3}]")
        })
        .collect();
    let text = format!(
        "name = \"bench\"\ntitle = \"Bench\"\nstart = {{ x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }}\nlandmarks = [{}]\n[trajectory]\nmax_speed_mps = 1.0\nlaps = 1\nwaypoints = [[{side}, 0], [{side}, {side}], [0, {side}], [0, 0]]\n",
        lms.join(", ")
    );
    let map = Map::from_toml(&text).unwrap();
    let sensor = PointSensorParams {
        max_range_m: 8.0,
        occlusion: false,
        max_observations: 20,
        ..PointSensorParams::default()
    };
    generate(
        &WorldSpec {
            map: &map,
            sim: &SimParams { dt_s: 0.1, ..SimParams::default() },
            odometry: &OdometryNoise::default(),
            laser: None,
            landmark_sensor: Some(&sensor),
        },
        3,
    )
    .unwrap()
}

/// Wall time per odometry step of `f` over `steps` steps [µs], and f's result.
fn per_step<T>(steps: usize, f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let out = black_box(f());
    (start.elapsed().as_secs_f64() * 1e6 / steps as f64, out)
}

fn main() {
    let motion = MotionModel::default();
    let ekf_params = EkfParams { association: EkfAssociation::Known, ..EkfParams::default() };
    let params = GraphParams::default();
    println!(
        "| landmarks (mapped) | steps | ekf_slam µs/step | graph_slam_batch µs/step | graph_slam (online) µs/step | one solve µs/step |"
    );
    println!("|---|---|---|---|---|---|");
    for n in [35, 1_000, 10_000] {
        let w = world(n);
        let z: Vec<StepObservations> = stream(&w, Source::Points).unwrap();
        let steps = w.odometry.len();
        let mapped = {
            let mut ids: Vec<usize> =
                z.iter().flat_map(|s| s.observations.iter().filter_map(|o| o.landmark)).collect();
            ids.sort_unstable();
            ids.dedup();
            ids.len()
        };
        let ekf = if n <= 1_000 {
            format!("{:.0}", per_step(steps, || ekf::run(&w, &motion, &ekf_params, &z, false)).0)
        } else {
            "not run (3.2 GB covariance)".into()
        };
        let (batch, online) = if n <= 35 {
            let batch = per_step(steps, || graph::run_batch(&w, &motion, &params, &z).unwrap()).0;
            let online = per_step(steps, || graph::run_online(&w, &motion, &params, &z).unwrap()).0;
            (format!("{batch:.0}"), format!("{online:.0}"))
        } else {
            ("not run: O(steps²)".into(), "not run: O(steps²)".into())
        };
        let mut at_truth = graph::graph_at_truth(&w, &motion, &params, &z).unwrap();
        let (solve, converged) = per_step(steps, || at_truth.solve());
        let note = if converged { "" } else { " (not converged)" };
        println!("| {n} ({mapped}) | {steps} | {ekf} | {batch} | {online} | {solve:.1}{note} |");
    }
}
