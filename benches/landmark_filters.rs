//! EKF-SLAM, FastSLAM 1.0 and FastSLAM 2.0 time per filter step on point-landmark worlds, against
//! the number of landmarks and of particles. Each case runs the filter over a whole short world
//! (a 20 × 20 m square driven once at 1 m/s, odometry at 10 Hz, range-bearing readings at 5 Hz of
//! every landmark within 10 m, known association) and reports the time per odometry step.
//! EKF-SLAM's cost grows with the square of the map size; FastSLAM's with particles × landmarks
//! in view (association by identity), not with the map size.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slamlab::slam::ekf::{self, EkfAssociation, EkfParams};
use slamlab::slam::fastslam::{self, DataAssociation, FastSlamParams};
use slamlab::slam::fastslam2;
use slamlab::slam::motion::MotionModel;
use slamlab::slam::observations::{Source, StepObservations, stream};
use slamlab::world::map::Map;
use slamlab::world::odometry::OdometryNoise;
use slamlab::world::point_sensor::PointSensorParams;
use slamlab::world::{SimParams, World, WorldSpec, generate};
use std::hint::black_box;

/// `n` landmarks scattered (seeded) around the square's path.
fn world(n: usize) -> World {
    let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
    let lms: Vec<String> = (0..n)
        .map(|_| {
            format!("[{:.3}, {:.3}]", rng.random_range(-5.0..25.0), rng.random_range(-5.0..25.0))
        })
        .collect();
    let text = format!(
        "name = \"bench\"\ntitle = \"Bench\"\nstart = {{ x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }}\nlandmarks = [{}]\n[trajectory]\nmax_speed_mps = 1.0\nlaps = 1\nwaypoints = [[20, 0], [20, 20], [0, 20], [0, 0]]\n",
        lms.join(", ")
    );
    let map = Map::from_toml(&text).unwrap();
    let sensor = PointSensorParams { max_range_m: 10.0, ..PointSensorParams::default() };
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

fn observations(world: &World) -> Vec<StepObservations> {
    stream(world, Source::Points).unwrap()
}

fn per_landmarks(c: &mut Criterion) {
    let motion = MotionModel::default();
    let ekf_params = EkfParams { association: EkfAssociation::Known, ..EkfParams::default() };
    let fs = FastSlamParams {
        particles: 100,
        association: DataAssociation::Known,
        ..FastSlamParams::default()
    };
    let mut g = c.benchmark_group("landmark_filters_per_step_vs_landmarks");
    g.sample_size(10);
    for n in [16, 64, 256] {
        let w = world(n);
        let z = observations(&w);
        g.throughput(Throughput::Elements(w.odometry.len() as u64 + 1));
        g.bench_function(BenchmarkId::new("ekf_slam", n), |b| {
            b.iter(|| black_box(ekf::run(&w, &motion, &ekf_params, &z, false).unwrap()))
        });
        g.bench_function(BenchmarkId::new("fastslam1_100p", n), |b| {
            b.iter(|| {
                black_box(
                    fastslam::run_on(
                        &w,
                        &fs,
                        Some(&motion),
                        &z,
                        false,
                        &mut ChaCha8Rng::seed_from_u64(1),
                    )
                    .unwrap(),
                )
            })
        });
        g.bench_function(BenchmarkId::new("fastslam2_100p", n), |b| {
            b.iter(|| {
                black_box(
                    fastslam2::run(&w, &fs, &motion, &z, false, &mut ChaCha8Rng::seed_from_u64(1))
                        .unwrap(),
                )
            })
        });
    }
    g.finish();
}

fn per_particles(c: &mut Criterion) {
    let motion = MotionModel::default();
    let w = world(35); // the 35-landmark case of the EKF peer figure
    let z = observations(&w);
    let mut g = c.benchmark_group("landmark_filters_per_step_vs_particles_35_landmarks");
    g.sample_size(10);
    g.throughput(Throughput::Elements(w.odometry.len() as u64 + 1));
    let ekf_params = EkfParams { association: EkfAssociation::Known, ..EkfParams::default() };
    g.bench_function("ekf_slam", |b| {
        b.iter(|| black_box(ekf::run(&w, &motion, &ekf_params, &z, false).unwrap()))
    });
    for particles in [10, 100, 1000] {
        let fs = FastSlamParams {
            particles,
            association: DataAssociation::Known,
            ..FastSlamParams::default()
        };
        g.bench_function(BenchmarkId::new("fastslam1", particles), |b| {
            b.iter(|| {
                black_box(
                    fastslam::run_on(
                        &w,
                        &fs,
                        Some(&motion),
                        &z,
                        false,
                        &mut ChaCha8Rng::seed_from_u64(1),
                    )
                    .unwrap(),
                )
            })
        });
        g.bench_function(BenchmarkId::new("fastslam2", particles), |b| {
            b.iter(|| {
                black_box(
                    fastslam2::run(&w, &fs, &motion, &z, false, &mut ChaCha8Rng::seed_from_u64(1))
                        .unwrap(),
                )
            })
        });
    }
    g.finish();
}

criterion_group!(benches, per_landmarks, per_particles);
criterion_main!(benches);
