//! A study's morris / sobol groups, analysed: for each (group, map, algorithm, metric) the
//! design rows' outputs are gathered from the runs and handed to [`crate::stats::sensitivity`].
//! What the report shows and index claims test.
//!
//! - **The output of a design row** is the mean of its point's values (of ln of each value for a
//!   metric in `[report] sensitivity_log`; a value ≤ 0 then counts as missing) over the
//!   replicates that every point of its Saltelli sample (A, B, every ABᵢ) or Morris trajectory
//!   has: replicate k of every point saw the same world (common random numbers), so a
//!   difference cancels that world only when both ends average the same replicates. A sample or
//!   trajectory with no replicate in common is dropped; the counts are reported.
//! - **Each parameter's noise term**: what run-to-run noise adds to its ST (or μ*), measured from
//!   the spread, across the common replicates, of the per-replicate differences its index is
//!   built from: mean over samples of var(d)/|C| / 2V for Jansen's ST (for two replicates,
//!   mean((d₀ − d₁)²)/(4·R·V)), E|noise|/Δ for μ*. Under common random numbers it is zero where
//!   a parameter changes nothing. Index claims and the report's findings clear this term, and
//!   ST − S1 too (noise raises ST, not S1); the noise floor below only scales S1 and ST.
//! - **Where the variance comes from**: a two-way ANOVA of the design's distinct points ×
//!   replicates splits it into the parameters, the world (replicate seed) and the residual.
//! - **Noise floor**: run-to-run noise that is independent between points adds to every
//!   parameter's estimate: to Jansen's STᵢ on average σ²/(R V) (σ² the residual mean square,
//!   R replicates averaged, V the variance of the averaged outputs), and to μ* about
//!   √(2σ²/R)·√(2/π)/Δ (the mean |difference| of two noisy outputs over the step). An index
//!   whose interval does not clear the floor cannot be told apart from simulation noise.

use crate::spec::SweepKind;
use crate::stats::sensitivity::{
    Screening, VarianceShares, screen, sobol_indices, variance_shares,
};
use crate::store::DesignRecord;
use crate::store::{RunStatus, StudyData};
use std::collections::{BTreeMap, HashMap};

/// Bootstrap resamples behind every interval.
pub const RESAMPLES: usize = 1000;

/// The pseudo-metric "did the run fail" (1 failed or diverged, 0 finished): analysed, beside
/// the report's metrics, for every design group in which some run failed — which parameters
/// drive failures (e.g. FastSLAM's map explosion) is itself a sensitivity question, and the
/// metrics' indices are computed without the failed points.
pub const FAILED: &str = "run_failed";

#[derive(Debug, Clone, PartialEq)]
pub enum Indices {
    /// S1 and ST per parameter, with their bootstrap replicates.
    Sobol(crate::stats::sensitivity::Indices),
    /// μ, μ*, σ per parameter.
    Morris(Vec<Screening>),
}

/// One (group, map, algorithm, metric).
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    pub group: usize,
    pub kind: SweepKind,
    pub map: String,
    pub algorithm: String,
    pub metric: String,
    /// The metric was analysed as ln(value) (`[report] sensitivity_log`).
    pub log: bool,
    pub params: Vec<String>,
    /// None when too few rows are usable (`note` says why).
    pub indices: Option<Indices>,
    pub shares: Option<VarianceShares>,
    /// ST's (sobol) or μ*'s (morris) expected value for a parameter without effect, were the
    /// noise independent between points (σ² / (R·V)); shown beside the indices.
    pub noise_floor: Option<f64>,
    /// Per parameter, what the noise adds to its ST (sobol) or μ* (morris) estimate, measured
    /// from its own differences across the replicates (common random numbers cancel the noise
    /// where a parameter changes nothing): what index claims and the report's findings clear.
    /// `None` with one replicate per point (nothing to measure it from).
    pub noise: Option<Vec<f64>>,
    /// Replicates per point.
    pub replicates: usize,
    /// Sobol: samples used of N; Morris: trajectories complete of r.
    pub used: usize,
    pub size: usize,
    /// Runs of the group's points on this map and algorithm, and how many failed.
    pub runs: usize,
    pub failed: usize,
    /// Each design row's output (the mean of its point's successful replicates; NaN: none).
    pub rows: Vec<f64>,
    pub note: String,
}

/// Every design group's analyses, in (group, map, algorithm, metric) order, of `metrics` (which
/// may include [`FAILED`]).
pub fn analyse(data: &StudyData, metrics: &[String]) -> Vec<Analysis> {
    let spec = &data.resolved.spec;
    // (map, algorithm, point) → replicate → metrics
    let mut cells: HashMap<(&str, &str), HashMap<&str, Vec<&crate::store::RunRow>>> =
        HashMap::new();
    for r in &data.runs {
        cells
            .entry((r.map.as_str(), r.algorithm.as_str()))
            .or_default()
            .entry(r.point.as_str())
            .or_default()
            .push(r);
    }
    let mut out = Vec::new();
    for (gi, group) in data.resolved.groups.iter().enumerate() {
        let Some(design) = &group.design else { continue };
        for map in &spec.maps {
            for algorithm in &spec.algorithms {
                let alg = algorithm.as_str();
                let of_cell = cells.get(&(map.as_str(), alg));
                for metric in metrics {
                    let seed = crate::plan::derive_seed(
                        spec.seed,
                        map,
                        gi as u32,
                        &format!("bootstrap:{alg}:{metric}"),
                    );
                    let log = spec.report.sensitivity_log.contains(metric);
                    out.push(one(
                        gi,
                        group.kind,
                        &group.params,
                        design,
                        |point| {
                            of_cell
                                .and_then(|c| c.get(point))
                                .map(Vec::as_slice)
                                .unwrap_or_default()
                        },
                        map,
                        alg,
                        metric,
                        log,
                        spec.replicates as usize,
                        seed,
                    ));
                }
            }
        }
    }
    out
}

#[allow(clippy::too_many_arguments)]
pub(super) fn one<'a, 'r: 'a>(
    gi: usize,
    kind: SweepKind,
    params: &[String],
    design: &DesignRecord,
    runs_of: impl Fn(&str) -> &'a [&'r crate::store::RunRow],
    map: &str,
    alg: &str,
    metric: &str,
    log: bool,
    replicates: usize,
    seed: u64,
) -> Analysis {
    let d = params.len();
    // what a run gives: [`FAILED`] is 1 for a failed run and 0 for a finished one; a metric is
    // read from finished runs only (ln of it on a log scale), None when it is not finite
    let value = |r: &crate::store::RunRow| -> Option<f64> {
        let ok = r.status == RunStatus::Ok;
        if metric == FAILED {
            return Some(if ok { 0.0 } else { 1.0 });
        }
        let v = r.metric(metric).filter(|_| ok)?;
        Some(if log { v.ln() } else { v }).filter(|v| v.is_finite())
    };
    // each distinct point once: its replicates' values
    let mut points: BTreeMap<&str, Vec<Option<f64>>> = BTreeMap::new();
    let (mut runs, mut failed) = (0, 0);
    for label in &design.rows {
        if points.contains_key(label.as_str()) {
            continue;
        }
        let mut reps = vec![None; replicates];
        for r in runs_of(label) {
            runs += 1;
            failed += usize::from(r.status != RunStatus::Ok);
            if let Some(slot) = reps.get_mut(r.replicate as usize) {
                *slot = value(r);
            }
        }
        points.insert(label, reps);
    }
    // A row's output is the mean of its point's values over the replicates that every point of
    // its Saltelli sample (or Morris trajectory) has: replicate k of every point saw the same
    // world, so a difference of two outputs cancels that world's noise only when both ends
    // average the same replicates (a failed replicate at one end drops it at the other).
    let per = match kind {
        SweepKind::Sobol => 0, // a sample's rows are strided: k, n + k, …, (d + 1)·n + k
        _ => d + 1,
    };
    let n = design.size;
    let group_rows = |g: usize| -> Vec<usize> {
        if per == 0 {
            (0..d + 2).map(|b| b * n + g).collect()
        } else {
            (g * per..(g + 1) * per).collect()
        }
    };
    let groups = if per == 0 { n } else { design.rows.len() / per.max(1) };
    let reps_of = |row: usize| &points[design.rows[row].as_str()];
    let mut y = vec![f64::NAN; design.rows.len()];
    // per group: the replicates common to its rows
    let mut common: Vec<Vec<usize>> = Vec::with_capacity(groups);
    for g in 0..groups {
        let rows = group_rows(g);
        let shared: Vec<usize> = (0..replicates)
            .filter(|&k| rows.iter().all(|&row| reps_of(row)[k].is_some()))
            .collect();
        if !shared.is_empty() {
            for &row in &rows {
                let vals = reps_of(row);
                y[row] = shared.iter().map(|&k| vals[k].expect("shared")).sum::<f64>()
                    / shared.len() as f64;
            }
        }
        common.push(shared);
    }
    // The noise in the difference of two averaged outputs of group g, rows `from` → `to`, as a
    // variance: the spread over the common replicates of the per-replicate differences, over their
    // number (None with fewer than two). Under common random numbers it is zero where the
    // change leaves every run unchanged.
    let noise_of = |g: usize, from: usize, to: usize| -> Option<f64> {
        let shared = &common[g];
        if shared.len() < 2 {
            return None;
        }
        let (a, b) = (reps_of(from), reps_of(to));
        let diffs: Vec<f64> =
            shared.iter().map(|&k| b[k].expect("shared") - a[k].expect("shared")).collect();
        let m = diffs.iter().sum::<f64>() / diffs.len() as f64;
        let var = diffs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (diffs.len() - 1) as f64;
        Some(var / diffs.len() as f64)
    };
    let complete: Vec<Vec<f64>> = points
        .values()
        .filter(|r| r.iter().all(Option::is_some))
        .map(|r| r.iter().flatten().copied().collect())
        .collect();
    let shares = variance_shares(&complete);
    let mut a = Analysis {
        group: gi,
        kind,
        map: map.to_string(),
        algorithm: alg.to_string(),
        metric: metric.to_string(),
        log,
        params: params.to_vec(),
        indices: None,
        shares,
        noise_floor: None,
        noise: None,
        replicates,
        used: 0,
        size: design.size,
        runs,
        failed,
        rows: y,
        note: String::new(),
    };
    let r = replicates as f64;
    let y = &a.rows;
    match kind {
        SweepKind::Sobol => {
            let keep: Vec<usize> =
                (0..n).filter(|&k| (0..d + 2).all(|block| y[block * n + k].is_finite())).collect();
            a.used = keep.len();
            if keep.len() < 8 {
                a.note = format!(
                    "only {} of {n} samples have a value at every one of their {} points: too few to estimate indices",
                    keep.len(),
                    d + 2
                );
                return a;
            }
            let fa: Vec<f64> = keep.iter().map(|&k| y[k]).collect();
            let fb: Vec<f64> = keep.iter().map(|&k| y[n + k]).collect();
            let fab: Vec<Vec<f64>> =
                (0..d).map(|i| keep.iter().map(|&k| y[(2 + i) * n + k]).collect()).collect();
            let mean = fa.iter().chain(&fb).sum::<f64>() / (2 * fa.len()) as f64;
            let v = fa.iter().chain(&fb).map(|x| (x - mean).powi(2)).sum::<f64>()
                / (2 * fa.len()) as f64;
            if v <= 0.0 {
                a.note = "the metric takes the same value at every sampled point: no variance to apportion".into();
                return a;
            }
            let idx = sobol_indices(&fa, &fb, &fab, RESAMPLES, seed);
            a.noise_floor = shares.filter(|_| replicates >= 2).map(|s| s.residual_var / r / v);
            // Jansen's ST_i = mean (f_A − f_ABi)² / 2V is raised by the noise of that difference:
            // its mean variance over the samples, / 2V
            a.noise = (0..d)
                .map(|i| {
                    let terms: Vec<f64> =
                        keep.iter().filter_map(|&k| noise_of(k, k, (2 + i) * n + k)).collect();
                    // (over the samples with two or more replicates in common)
                    (!terms.is_empty())
                        .then(|| terms.iter().sum::<f64>() / terms.len() as f64 / (2.0 * v))
                })
                .collect();
            a.indices = Some(Indices::Sobol(idx));
        }
        SweepKind::Morris => {
            let trajectories: Vec<Vec<Vec<f64>>> =
                design.unit.chunks(per).map(<[Vec<f64>]>::to_vec).collect();
            let f: Vec<Vec<f64>> = y.chunks(per).map(<[f64]>::to_vec).collect();
            a.used = f.iter().filter(|t| t.iter().all(|v| v.is_finite())).count();
            if f.iter().flatten().all(|v| !v.is_finite()) {
                a.note = "no design point has a value".into();
                return a;
            }
            let s = screen(&trajectories, &design.moved, &f, RESAMPLES, seed);
            let delta = design.delta.unwrap_or(f64::NAN);
            a.noise_floor = shares.filter(|_| replicates >= 2).map(|s| {
                (2.0 * s.residual_var / r).sqrt() * (2.0 / std::f64::consts::PI).sqrt() / delta
            });
            // μ*_i is raised by E|noise| of its steps' differences, √(2 var / π), over the step
            a.noise = (0..d)
                .map(|i| {
                    let mut terms = Vec::new();
                    for (t, order) in design.moved.iter().enumerate() {
                        for (k, &j) in order.iter().enumerate().filter(|(_, j)| **j == i) {
                            let step = (trajectories[t][k + 1][j] - trajectories[t][k][j]).abs();
                            if step > 0.0 && f[t][k].is_finite() && f[t][k + 1].is_finite() {
                                let var = noise_of(t, t * per + k, t * per + k + 1)?;
                                terms.push((2.0 * var / std::f64::consts::PI).sqrt() / step);
                            }
                        }
                    }
                    (!terms.is_empty()).then(|| terms.iter().sum::<f64>() / terms.len() as f64)
                })
                .collect();
            a.indices = Some(Indices::Morris(s));
        }
        _ => unreachable!("only design groups are analysed"),
    }
    a
}

/// A Saltelli design over the unit square (d = 2) and its runs: `y(x, replicate, row)` is a run's
/// metric `y`, `None` for a failed run. For the tests here and in `claims`.
#[cfg(test)]
pub(super) fn saltelli_runs(
    n: usize,
    seed: u64,
    replicates: u32,
    y: impl Fn(&[f64], u32, usize) -> Option<f64>,
) -> (DesignRecord, Vec<crate::store::RunRow>) {
    let unit = crate::stats::sensitivity::Saltelli::new(n, 2, seed);
    let rows: Vec<Vec<f64>> =
        unit.a.iter().chain(&unit.b).chain(unit.ab.iter().flatten()).cloned().collect();
    let labels: Vec<String> = (0..rows.len()).map(|i| format!("p{i}")).collect();
    let mut runs = Vec::new();
    for (i, x) in rows.iter().enumerate() {
        for rep in 0..replicates {
            let value = y(x, rep, i);
            runs.push(crate::store::RunRow {
                study: "s".into(),
                run_id: format!("{i}-{rep}"),
                map: "m".into(),
                algorithm: "odometry".into(),
                point: labels[i].clone(),
                replicate: rep,
                world_seed: 0,
                filter_seed: 0,
                status: if value.is_some() { RunStatus::Ok } else { RunStatus::Failed },
                error: None,
                run_hash: String::new(),
                params_hash: String::new(),
                code_version: String::new(),
                params: Vec::new(),
                metrics: value.map(|v| vec![("y".into(), v)]).unwrap_or_default(),
            });
        }
    }
    let design =
        DesignRecord { size: n, rows: labels, moved: Vec::new(), unit: Vec::new(), delta: None };
    (design, runs)
}

/// `runs` by sweep point.
#[cfg(test)]
pub(super) fn by_point(runs: &[crate::store::RunRow]) -> HashMap<&str, Vec<&crate::store::RunRow>> {
    let mut m: HashMap<&str, Vec<&crate::store::RunRow>> = HashMap::new();
    for r in runs {
        m.entry(r.point.as_str()).or_default().push(r);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analysis of metric `y` of a two-parameter (a, b) Saltelli design's runs.
    fn sobol_of(
        design: &DesignRecord,
        runs: &[crate::store::RunRow],
        replicates: usize,
    ) -> Analysis {
        let cells = by_point(runs);
        one(
            0,
            SweepKind::Sobol,
            &["a".into(), "b".into()],
            design,
            |p| cells.get(p).map(Vec::as_slice).unwrap_or_default(),
            "m",
            "odometry",
            "y",
            false,
            replicates,
            1,
        )
    }

    /// A two-parameter Saltelli design whose "runs" compute y = 4 x₁ + x₂ + noise(replicate):
    /// S1 ≈ ST ≈ 16/17 and 1/17, the world's share is what the replicate offsets make it, and a
    /// failed run drops exactly its sample.
    #[test]
    fn sobol_group_from_runs() {
        let n = 64;
        let (design, runs) = saltelli_runs(n, 9, 3, |x, rep, i| {
            (!(i == 5 && rep == 0)).then(|| 4.0 * x[0] + x[1] + 0.1 * f64::from(rep))
        });
        let rows = design.rows.len();
        let a = sobol_of(&design, &runs, 3);
        let Some(Indices::Sobol(x)) = &a.indices else { panic!("{}", a.note) };
        let (s1, st) = (&x.s1, &x.st);
        assert!(
            (s1[0].value - 16.0 / 17.0).abs() < 0.08 && (st[0].value - 16.0 / 17.0).abs() < 0.05,
            "{s1:?} {st:?}"
        );
        assert!((st[1].value - 1.0 / 17.0).abs() < 0.02, "{st:?}");
        assert_eq!(
            (a.runs, a.failed, a.used),
            (rows * 3, 1, n),
            "a failed replicate leaves its point averaged over the other two"
        );
        let shares = a.shares.unwrap();
        assert!(
            shares.world > 0.0 && shares.residual < 1e-12,
            "additive replicate offsets are the world's share: {shares:?}"
        );
    }

    /// Replicate k of every point sees the same world, here an offset of 10·k. A failed run at one
    /// end of a difference must not leave the two ends averaging different replicates: b has no
    /// effect, and one failed replicate of one of its AB rows once gave it an ST of about 0.15
    /// (the offset leaking into one difference); both ends now average the replicates they
    /// share. The per-parameter noise terms are zero: the world's noise cancels in every
    /// difference.
    #[test]
    fn a_failed_replicate_drops_it_at_both_ends_of_a_difference() {
        let n = 64;
        let broken = 3 * n + 5; // sample 5's AB_b row
        let (design, runs) = saltelli_runs(n, 9, 2, |x, rep, i| {
            (!(i == broken && rep == 0)).then(|| 4.0 * x[0] + 10.0 * f64::from(rep))
        });
        let a = sobol_of(&design, &runs, 2);
        let Some(Indices::Sobol(x)) = &a.indices else { panic!("{}", a.note) };
        assert!(x.st[1].value.abs() < 1e-12, "b has no effect: ST {:?}", x.st[1]);
        assert_eq!(a.used, n, "the sample keeps the replicate all its points have");
        let noise = a.noise.expect("two replicates");
        assert!(noise.iter().all(|t| t.abs() < 1e-12), "{noise:?}");
    }
}
