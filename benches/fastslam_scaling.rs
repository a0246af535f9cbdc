//! FastSLAM 1.0 and 2.0 CPU time per observation as the map grows (issue 29 item 1): 100
//! particles, known association, on the worlds of the performance review
//! (`../shared/reviews/performance.md` §2.2) — Bailey's webmap route (its 17 waypoints, two laps,
//! 19 465 steps at 40 Hz) through 35 (the webmap's own), 1 000 and 10 000 landmarks (uniform over
//! [−130, 105] × [−100, 95] m, seeded), read at 5 Hz within 30 m and 180°. Per observation =
//! (the run − the same run on `farland`, one landmark never in range: prediction, resampling
//! and start-up) ÷ observations. FastSLAM's promise (Montemerlo et al. 2002) is a cost per
//! observation that barely grows with the map: the goal is ≤ 3× from 35 to 10 000.
//!
//! A plain harness (`harness = false`): each case is the median of 9 runs (3 above 100 000
//! observations, 1 above a million), timed in CPU seconds of the running thread (so waiting for a
//! core on a shared machine is not counted), and the table is printed as Markdown. Skipped with a
//! message when `../shared/data/bailey-sim-maps` is absent. 100 000 landmarks (about 3 000
//! readings per reading step, 100 maps of up to 78 000 landmarks) runs because the maps share
//! their blocks (`particle::Map`): before, it needed about 5 GB (the review's 250 MB for 7 868).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slamlab::slam::fastslam::{self, DataAssociation, FastSlamParams};
use slamlab::slam::fastslam2;
use slamlab::slam::motion::MotionModel;
use slamlab::slam::observations::{Source, stream};
use slamlab::world::map::Map;
use slamlab::world::odometry::OdometryNoise;
use slamlab::world::point_sensor::PointSensorParams;
use slamlab::world::{SimParams, World, WorldSpec, generate};
use std::path::Path;
use std::time::Instant;

fn csv(path: &Path) -> Vec<(f64, f64)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut f = l.split(',').map(|v| v.trim().parse::<f64>().unwrap());
            (f.next().unwrap(), f.next().unwrap())
        })
        .collect()
}

fn world(landmarks: &[(f64, f64)], waypoints: &[(f64, f64)]) -> World {
    let fmt = |p: &[(f64, f64)]| {
        p.iter().map(|(x, y)| format!("[{x:?}, {y:?}]")).collect::<Vec<_>>().join(", ")
    };
    let text = format!(
        "name = \"bench\"\ntitle = \"Bench\"\nstart = {{ x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }}\nlandmarks = [{}]\n[trajectory]\nmax_speed_mps = 3.0\nmax_turn_rate_dps = 21.485917\nlaps = 2\nwaypoint_tolerance_m = 1.0\nwaypoints = [{}]\n",
        fmt(landmarks),
        fmt(waypoints)
    );
    let map = Map::from_toml(&text).unwrap();
    let sensor = PointSensorParams {
        max_range_m: 30.0,
        fov_deg: 180.0,
        rate_hz: 5.0,
        range_sigma_m: 0.1,
        bearing_sigma_rad: 0.01745329,
        occlusion: false,
        ..PointSensorParams::default()
    };
    generate(
        &WorldSpec {
            map: &map,
            sim: &SimParams { dt_s: 0.025, ..SimParams::default() },
            odometry: &OdometryNoise::Pose {
                var_x_m2: 3.583563e-05,
                var_y_m2: 3.583563e-05,
                var_theta_rad2: 9.638286e-07,
            },
            laser: None,
            landmark_sensor: Some(&sensor),
        },
        1,
    )
    .unwrap()
}

/// CPU-bound wall seconds of `which` (1 or 2) on `world`: the median of `repeats` runs.
fn seconds(world: &World, which: u8, repeats: usize) -> f64 {
    let mut s: Vec<f64> = (0..repeats).map(|_| one_run(world, which)).collect();
    s.sort_by(f64::total_cmp);
    s[repeats / 2]
}

/// Seconds this thread has run on a CPU (`/proc/thread-self/schedstat`, nanoseconds): time spent
/// waiting for a core on a shared machine is not counted. `None` where the kernel lacks it.
fn thread_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(text.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}

/// CPU seconds of one run (single-threaded, CPU-bound); wall seconds without schedstat.
fn one_run(world: &World, which: u8) -> f64 {
    let z = stream(world, Source::Points).unwrap();
    let motion = MotionModel::Pose {
        sigma_x_m: 5.986287e-03,
        sigma_y_m: 5.986287e-03,
        sigma_theta_rad: 9.817477e-04,
    };
    let params = FastSlamParams {
        particles: 100,
        p0: 0.005,
        neff_threshold: 75.0,
        association: DataAssociation::Known,
        max_landmarks: 200_000,
        ..FastSlamParams::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (start, cpu) = (Instant::now(), thread_cpu_seconds());
    let trace = match which {
        1 => fastslam::run_on(world, &params, Some(&motion), &z, false, &mut rng),
        _ => fastslam2::run(world, &params, &motion, &z, false, &mut rng),
    }
    .unwrap();
    let s = match (cpu, thread_cpu_seconds()) {
        (Some(a), Some(b)) => b - a,
        _ => start.elapsed().as_secs_f64(),
    };
    std::hint::black_box(trace);
    s
}

fn main() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/bailey-sim-maps");
    if !folder.is_dir() {
        println!("fastslam_scaling: skipped, ../shared/data/bailey-sim-maps is absent");
        return;
    }
    let waypoints = csv(&folder.join("example_webmap_waypoints.csv"));
    let webmap = csv(&folder.join("example_webmap_landmarks.csv"));
    let synthetic = |n: usize| -> Vec<(f64, f64)> {
        let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
        (0..n).map(|_| (rng.random_range(-130.0..105.0), rng.random_range(-100.0..95.0))).collect()
    };
    let far = world(&[(10_000.0, 10_000.0)], &waypoints);
    let cases = [
        ("35 (webmap)", webmap),
        ("1 000", synthetic(1_000)),
        ("10 000", synthetic(10_000)),
        ("100 000", synthetic(100_000)),
    ];
    println!(
        "\n| landmarks | observations | FastSLAM 1.0 µs/observation | FastSLAM 2.0 µs/observation |"
    );
    println!("|---|---|---|---|");
    // the small cases differ from `farland` by a few per cent of a run: more repeats
    let base = [seconds(&far, 1, 9), seconds(&far, 2, 9)];
    let mut first = None;
    for (name, landmarks) in cases {
        let w = world(&landmarks, &waypoints);
        let n: usize =
            stream(&w, Source::Points).unwrap().iter().map(|s| s.observations.len()).sum();
        let repeats = match n {
            ..=100_000 => 9,
            ..=1_000_000 => 3,
            _ => 1,
        };
        let per = [1, 2].map(|f| (seconds(&w, f, repeats) - base[f as usize - 1]) / n as f64 * 1e6);
        let first = *first.get_or_insert(per);
        println!(
            "| {name} | {n} | {:.1} ({:.2}×) | {:.1} ({:.2}×) |",
            per[0],
            per[0] / first[0],
            per[1],
            per[1] / first[1]
        );
    }
}
