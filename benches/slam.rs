//! FastSLAM 1.0 time per filter step against the particle count and the map size. Each case
//! warms a filter up over the first 60 % of a run (so its maps are built), then times the next
//! 50 steps from a copy of that state.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::Matrix2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slamlab::features::FeatureParams;
use slamlab::geom::Pose2;
use slamlab::slam::fastslam::{FastSlam1, FastSlamParams};
use slamlab::slam::observations::{Observation, Source, stream};
use slamlab::world::laser::LaserParams;
use slamlab::world::map::Map;
use slamlab::world::odometry::OdometryNoise;
use slamlab::world::{SimParams, World, WorldSpec, generate};
use std::hint::black_box;

const MEASURED_STEPS: usize = 50;

fn world_of(map: &Map) -> World {
    let sim = SimParams { dt_s: 0.2, ..SimParams::default() };
    let laser = LaserParams {
        resolution_deg: 0.5,
        rate_hz: 5.0,
        range_sigma_m: 0.0,
        ..LaserParams::default()
    };
    generate(
        &WorldSpec {
            map,
            sim: &sim,
            odometry: &OdometryNoise::default(),
            laser: Some(&laser),
            landmark_sensor: None,
        },
        9,
    )
    .unwrap()
}

/// (control, features) for every step of a world.
fn steps(world: &World, params: &FastSlamParams) -> Vec<(Option<Pose2>, Vec<Observation>)> {
    let line_r = Matrix2::new(params.obs_var_rho_m2, 0.0, 0.0, params.obs_var_theta_rad2);
    let mut observed =
        stream(world, Source::LaserFeatures { features: &FeatureParams::default(), line_r })
            .unwrap()
            .into_iter()
            .peekable();
    (0..=world.odometry.len())
        .map(|k| {
            let control = k.checked_sub(1).map(|j| world.odometry[j]);
            let z = match observed.peek() {
                Some(s) if s.step == k => observed.next().unwrap().observations,
                _ => Vec::new(),
            };
            (control, z)
        })
        .collect()
}

fn bench_case(
    c: &mut Criterion,
    group: &str,
    id: BenchmarkId,
    world: &World,
    params: &FastSlamParams,
) {
    let steps = steps(world, params);
    let warm = steps.len() * 6 / 10;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut filter = FastSlam1::new(params, None, world.truth[0]);
    for (u, z) in &steps[..warm] {
        filter.step(u.as_ref(), z, &mut rng);
    }
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(MEASURED_STEPS as u64));
    g.bench_function(id, |b| {
        b.iter(|| {
            let mut f = filter.clone();
            let mut r = rng.clone();
            for (u, z) in &steps[warm..warm + MEASURED_STEPS] {
                black_box(f.step(u.as_ref(), z, &mut r));
            }
            f
        })
    });
    g.finish();
}

fn load(name: &str) -> Map {
    Map::from_toml(
        &std::fs::read_to_string(format!("{}/data/maps/{name}.toml", env!("CARGO_MANIFEST_DIR")))
            .unwrap(),
    )
    .unwrap()
}

/// A 10 × 6 m room with a 5 × 5 grid of 0.6 m blocks: 25 blocks, 100 corners.
fn blocks() -> Map {
    let mut text = String::from(
        "name = \"blocks\"\ntitle = \"Blocks\"\nstart = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }\n[[walls]]\npoints = [[-1, -1], [11, -1], [11, 7], [-1, 7], [-1, -1]]\n",
    );
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (1.0 + 2.0 * i as f64, 0.7 + 1.2 * j as f64);
            text.push_str(&format!(
                "[[walls]]\npoints = [[{x}, {y}], [{}, {y}], [{}, {}], [{x}, {}], [{x}, {y}]]\n",
                x + 0.6,
                x + 0.6,
                y + 0.5,
                y + 0.5
            ));
        }
    }
    text.push_str("[trajectory]\nmax_speed_mps = 0.5\nlaps = 2\nwaypoints = [[10, 0], [10, 6.3], [0, 6.3], [0, 0]]\n");
    Map::from_toml(&text).unwrap()
}

fn per_particles(c: &mut Criterion) {
    let world = world_of(&load("bigloop2"));
    for particles in [10, 100, 1000] {
        let params = FastSlamParams {
            particles,
            motion_x: 0.01,
            motion_y: 0.01,
            motion_theta: 0.008,
            ..FastSlamParams::default()
        };
        bench_case(
            c,
            "fastslam1_step_bigloop2",
            BenchmarkId::new("particles", particles),
            &world,
            &params,
        );
    }
}

fn per_map(c: &mut Criterion) {
    let params = FastSlamParams {
        motion_x: 0.01,
        motion_y: 0.01,
        motion_theta: 0.008,
        ..FastSlamParams::default()
    };
    for (name, map) in [
        ("recinto_basico", load("recinto_basico")),
        ("complex", load("complex")),
        ("blocks_100_corners", blocks()),
    ] {
        let world = world_of(&map);
        bench_case(
            c,
            "fastslam1_step_100_particles",
            BenchmarkId::new("map", format!("{name}_{}_landmarks", map.landmark_count())),
            &world,
            &params,
        );
    }
}

criterion_group!(benches, per_particles, per_map);
criterion_main!(benches);
