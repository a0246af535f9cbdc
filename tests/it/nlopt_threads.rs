//! Seeded NLopt searches are reproducible whatever runs beside them: NLopt's Mersenne Twister is
//! thread-local in this build (`THREADLOCAL` = `__thread`) and `search::simultaneous` reseeds it
//! on the calling thread before every optimisation. Runs execute on rayon threads in the
//! pipeline, so same seed ⇒ same result regardless of threads is required.

use slamlab::geom::Pose2;
use slamlab::scanmatch::MatchResult;
use slamlab::scanmatch::objective::{Objective, ObjectiveParams};
use slamlab::scanmatch::scan::PolarScan;
use slamlab::scanmatch::scan::testing::room_pair;
use slamlab::scanmatch::search::{Optimizer, SearchParams, simultaneous};
use std::sync::Barrier;

const TRUTH: Pose2 = Pose2::new(0.2, -0.1, 0.05235987755982988); // 3°
const GUESS: Pose2 = Pose2::new(0.23, -0.14, 0.017453292519943295); // 1°
const STOCHASTIC: [Optimizer; 2] = [Optimizer::Crs2, Optimizer::Isres];
const SEEDS: [u64; 2] = [17, 18];
const THREADS: usize = 4;
const REPEATS: usize = 8;

fn params() -> SearchParams {
    SearchParams { maxeval: 800, ..SearchParams::default() }
}

fn run(scans: &(PolarScan, PolarScan), optimizer: Optimizer, seed: u64) -> MatchResult {
    let mut cost = Objective::new(&scans.0, &scans.1, &ObjectiveParams::default());
    simultaneous(&mut cost, GUESS, optimizer, &params(), seed)
}

#[test]
fn seeded_searches_are_identical_on_concurrent_threads() {
    let scans = room_pair(TRUTH);
    // References, computed alone on this thread.
    let reference: Vec<Vec<MatchResult>> =
        STOCHASTIC.iter().map(|&o| SEEDS.iter().map(|&s| run(&scans, o, s)).collect()).collect();
    // The test can fail: the two seeds must give different searches.
    for (o, results) in STOCHASTIC.iter().zip(&reference) {
        assert_ne!(results[0], results[1], "{o:?}: seeds {SEEDS:?} gave identical results");
    }

    // Threads interleave searches with different seeds, starting together.
    let barrier = Barrier::new(THREADS);
    std::thread::scope(|scope| {
        for t in 0..THREADS {
            let (scans, reference, barrier) = (&scans, &reference, &barrier);
            scope.spawn(move || {
                barrier.wait();
                for k in 0..REPEATS {
                    for (a, &o) in STOCHASTIC.iter().enumerate() {
                        let s = (t + k + a) % SEEDS.len();
                        let r = run(scans, o, SEEDS[s]);
                        assert_eq!(
                            r, reference[a][s],
                            "thread {t}, repeat {k}, {o:?}, seed {}",
                            SEEDS[s]
                        );
                    }
                }
            });
        }
    });
}

#[test]
fn every_optimizer_is_reproducible_on_a_fresh_thread() {
    let scans = room_pair(TRUTH);
    let params = SearchParams { maxeval: 300, ..SearchParams::default() };
    let run = |o: Optimizer| {
        let mut cost = Objective::new(&scans.0, &scans.1, &ObjectiveParams::default());
        simultaneous(&mut cost, GUESS, o, &params, 5)
    };
    let here: Vec<MatchResult> = Optimizer::ALL.iter().map(|&o| run(o)).collect();
    let there: Vec<MatchResult> = std::thread::scope(|scope| {
        scope.spawn(|| Optimizer::ALL.iter().map(|&o| run(o)).collect()).join().unwrap()
    });
    assert_eq!(here, there);
}

/// Every optimiser, the deterministic ones included, gives its lone result while the others run
/// on other threads (a non-reentrant NLopt routine would let concurrent runs disturb each other,
/// and the pipeline runs matches on rayon threads).
#[test]
fn every_optimizer_is_identical_on_concurrent_threads() {
    let scans = room_pair(TRUTH);
    let params = SearchParams { maxeval: 300, ..SearchParams::default() };
    let run = |o: Optimizer| {
        let mut cost = Objective::new(&scans.0, &scans.1, &ObjectiveParams::default());
        simultaneous(&mut cost, GUESS, o, &params, 5)
    };
    let alone: Vec<MatchResult> = Optimizer::ALL.iter().map(|&o| run(o)).collect();
    let barrier = Barrier::new(THREADS);
    std::thread::scope(|scope| {
        for t in 0..THREADS {
            let (alone, barrier, run) = (&alone, &barrier, &run);
            scope.spawn(move || {
                barrier.wait();
                for k in 0..3 {
                    for a in 0..Optimizer::ALL.len() {
                        // each thread runs a different optimiser at the same time
                        let i = (a + t * 3 + k) % Optimizer::ALL.len();
                        assert_eq!(
                            run(Optimizer::ALL[i]),
                            alone[i],
                            "thread {t}, round {k}, {:?}",
                            Optimizer::ALL[i]
                        );
                    }
                }
            });
        }
    });
}
