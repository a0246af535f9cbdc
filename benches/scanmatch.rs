//! Scan matching ([EP]) time per match.
//!
//! - `objective`: one evaluation of f (projection, interpolation, z-buffer, occlusion rule) on a
//!   181-beam pair of the synthetic room.
//! - `synthetic`: one match of every matcher on a noise-free room pair (true change 0.2 m,
//!   −0.1 m, 3°; initial guess 5 cm and 2° off), preparation included.
//! - `intel`: consecutive pairs of the Intel lab log (`../shared/data/intel-lab`, skipped with a
//!   message when absent), initial guess = the corrected increment; targets: E-PSM ≤ 5 ms, CRS2
//!   ≤ 20 ms. PL-ICP (issue 28) beside PSM, both with their preparation: PSM segments into lines,
//!   PL-ICP takes the raw points as CSM does.
//! - `diosi_reference`: PSM on the 3 636 matches of `../shared/data/psm-reference/intel-pairs.csv`
//!   (scans prepared once, as Diosi's program does), to set beside the C program's own time on the
//!   same matches (README "Benchmarks"); skipped with a message when absent. Timed twice: as
//!   the pipeline runs it (scored with the common objective), and PSM alone, as the C driver
//!   times `pm_psm`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use slamlab::geom::Pose2;
use slamlab::scanmatch::Cost;
use slamlab::scanmatch::brute::{BruteForceParams, brute_force};
use slamlab::scanmatch::epsm::{EpsmParams, epsm};
use slamlab::scanmatch::objective::{Objective, ObjectiveParams};
use slamlab::scanmatch::plicp::{PlIcpParams, pl_icp};
use slamlab::scanmatch::psm::{PsmParams, psm};
use slamlab::scanmatch::scan::PolarScan;
use slamlab::scanmatch::scan::testing::{
    Beams, MAX_RANGE_M, ROOM_REFERENCE_POSE, raw_pair, rect_room_with_column,
};
use slamlab::scanmatch::search::{Optimizer, SearchParams, simultaneous};
use slamlab::scanmatch::segment::{Segmentation, SegmentationParams, prepare};
use std::hint::black_box;
use std::path::Path;

const TRUTH: Pose2 = Pose2::new(0.2, -0.1, 0.052_359_877_559_829_88);
const GUESS: Pose2 = Pose2::new(0.25, -0.1, 0.017_453_292_519_943_295);

/// The matchers benchmarked, by their study names.
const MATCHERS: [&str; 6] = ["psm_original", "psm", "epsm", "epsm_table5", "crs2", "brute_force"];

fn segmentation(matcher: &str) -> SegmentationParams {
    let method = match matcher {
        "psm_original" => Segmentation::PsmHeuristics,
        "pl_icp" => Segmentation::None, // CSM works on the raw points
        _ => Segmentation::Lines,
    };
    SegmentationParams { method, ..SegmentationParams::default() }
}

/// Prepares both scans and runs one match; returns the final f (to keep the work alive).
fn run(
    matcher: &str,
    raw: (&[Option<f64>], &[Option<f64>]),
    geometry: (f64, f64, f64),
    initial: Pose2,
) -> f64 {
    let seg = segmentation(matcher);
    let (min, inc, max) = geometry;
    let (r, c): (PolarScan, PolarScan) =
        (prepare(raw.0, min, inc, max, &seg), prepare(raw.1, min, inc, max, &seg));
    let params = ObjectiveParams::default();
    let mut cost = Objective::new(&r, &c, &params);
    let m = match matcher {
        "psm_original" | "psm" => {
            psm(&r, &c, initial, &PsmParams::default(), &mut cost).expect("one laser")
        }
        "epsm" => epsm(&mut cost, initial, &EpsmParams::default()),
        "epsm_table5" => epsm(&mut cost, initial, &EpsmParams::table5()),
        "crs2" => simultaneous(&mut cost, initial, Optimizer::Crs2, &SearchParams::default(), 7),
        "pl_icp" => pl_icp(&r, &c, initial, &PlIcpParams::default(), &mut cost),
        _ => brute_force(&mut cost, initial, &BruteForceParams::default()),
    };
    m.f
}

fn objective(c: &mut Criterion) {
    let beams = Beams::lms200();
    let (r, cur) = raw_pair(&rect_room_with_column(), ROOM_REFERENCE_POSE, TRUTH, &beams);
    let seg = segmentation("epsm");
    let prep = |raw: &[Option<f64>]| {
        prepare(raw, beams.angle_min_rad, beams.angle_increment_rad, MAX_RANGE_M, &seg)
    };
    let (r, cur) = (prep(&r), prep(&cur));
    let params = ObjectiveParams::default();
    let mut cost = Objective::new(&r, &cur, &params);
    c.bench_function("scanmatch/objective_181_beams", |b| {
        b.iter(|| black_box(cost.f(black_box(GUESS))))
    });
}

fn synthetic(c: &mut Criterion) {
    let beams = Beams::lms200();
    let (r, cur) = raw_pair(&rect_room_with_column(), ROOM_REFERENCE_POSE, TRUTH, &beams);
    let geometry = (beams.angle_min_rad, beams.angle_increment_rad, MAX_RANGE_M);
    let mut group = c.benchmark_group("scanmatch/synthetic_match");
    group.sample_size(10);
    for matcher in MATCHERS {
        group.bench_with_input(BenchmarkId::from_parameter(matcher), &matcher, |b, m| {
            b.iter(|| black_box(run(m, (&r, &cur), geometry, GUESS)))
        });
    }
    group.finish();
}

/// Consecutive pairs of the Intel lab log.
const INTEL_PAIRS: usize = 50;

fn intel(c: &mut Criterion) {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/intel-lab");
    if !folder.is_dir() {
        eprintln!("skipped: scanmatch/intel: {} is absent", folder.display());
        return;
    }
    let world = slamlab::dataset::intel_lab::load(
        &folder,
        100,
        INTEL_PAIRS + 1,
        slamlab::dataset::intel_lab::DEFAULT_MAX_RANGE_M,
    )
    .expect("the Intel log reads");
    let g = world.laser.expect("laser");
    let geometry = (g.angle_min_rad, g.angle_increment_rad, g.max_range_m);
    let mut group = c.benchmark_group("scanmatch/intel_match");
    group.sample_size(10);
    group.throughput(Throughput::Elements(INTEL_PAIRS as u64));
    for matcher in ["psm_original", "psm", "epsm", "crs2", "pl_icp"] {
        group.bench_with_input(BenchmarkId::from_parameter(matcher), &matcher, |b, m| {
            b.iter(|| {
                let mut total = 0.0;
                for k in 0..INTEL_PAIRS {
                    let f = run(
                        m,
                        (&world.scans[k].ranges_m, &world.scans[k + 1].ranges_m),
                        geometry,
                        world.odometry[k],
                    );
                    total += if f.is_finite() { f } else { 0.0 };
                }
                black_box(total)
            })
        });
    }
    group.finish();
}

/// PSM on the Intel reference matches: every row of `intel-pairs.csv`, scans prepared once.
fn diosi_reference(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    let (csv, folder) = (root.join("psm-reference/intel-pairs.csv"), root.join("intel-lab"));
    if !csv.is_file() || !folder.is_dir() {
        eprintln!(
            "skipped: scanmatch/diosi_reference: {} or {} is absent",
            csv.display(),
            folder.display()
        );
        return;
    }
    let world = slamlab::dataset::intel_lab::load(&folder, 0, 0, 1e3).expect("the Intel log reads");
    let g = world.laser.expect("laser");
    let params = PsmParams::default();
    let heuristics = slamlab::scanmatch::segment::PsmHeuristicsParams::default();
    let scans: Vec<PolarScan> = world
        .scans
        .iter()
        .map(|s| {
            slamlab::scanmatch::segment::psm_heuristics(
                &s.ranges_m,
                g.angle_min_rad,
                g.angle_increment_rad,
                params.max_range_m,
                &heuristics,
            )
        })
        .collect();
    let text = std::fs::read_to_string(&csv).expect("the reference reads");
    let rows: Vec<(usize, usize, Pose2)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |k: usize| f[k].parse::<f64>().expect("a number");
            (n(1) as usize, n(2) as usize, Pose2::new(n(4), n(5), n(6)))
        })
        .collect();
    let mut group = c.benchmark_group("scanmatch/diosi_reference");
    group.sample_size(10);
    group.throughput(Throughput::Elements(rows.len() as u64));
    group.bench_function("psm_original", |b| {
        b.iter(|| {
            let mut total = 0.0;
            for &(r, k, guess) in &rows {
                let mut cost = Objective::new(&scans[r], &scans[k], &ObjectiveParams::default());
                let m = psm(&scans[r], &scans[k], guess, &params, &mut cost).expect("one laser");
                total += m.pose.x;
            }
            black_box(total)
        })
    });
    // PSM alone, as Diosi's driver times `pm_psm`: the common objective that scores every match
    // (f at the guess and at the estimate) is the pipeline's, not PSM's, and is left out here.
    group.bench_function("psm_original, without scoring", |b| {
        b.iter(|| {
            let mut total = 0.0;
            for &(r, k, guess) in &rows {
                let m =
                    psm(&scans[r], &scans[k], guess, &params, &mut Unscored).expect("one laser");
                total += m.pose.x;
            }
            black_box(total)
        })
    });
    group.finish();
}

/// A cost that judges nothing (f = NaN): PSM's own result does not use it.
struct Unscored;

impl Cost for Unscored {
    fn f(&mut self, _: Pose2) -> f64 {
        f64::NAN
    }
    fn residuals(&mut self, _: Pose2, out: &mut [f64]) -> usize {
        out.fill(f64::NAN);
        0
    }
    fn beams(&self) -> usize {
        0
    }
    fn evaluations(&self) -> u64 {
        0
    }
}

criterion_group!(benches, objective, synthetic, intel, diosi_reference);
criterion_main!(benches);
