//! A study's morris / sobol groups, analysed: for each (group, map, algorithm, metric) the
//! design rows' outputs are gathered from the runs and handed to [`crate::stats::sensitivity`].
//! What the report shows and index claims test.
//!
//! - **The output of a design row** is the mean of its point's successful replicates (of ln of
//!   each value for a metric in `[report] sensitivity_log`; a value ≤ 0 then counts as missing) (replicate
//!   k of every point saw the same world: common random numbers). A row whose point has no
//!   finite value drops its whole Saltelli sample (A, B and every ABᵢ of that sample) or, in a
//!   Morris trajectory, the effects of the steps that touch it; the counts are reported.
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
    /// ST's (sobol) or μ*'s (morris) expected value for a parameter without effect.
    pub noise_floor: Option<f64>,
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
fn one<'a, 'r: 'a>(
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
    // a row's output: the mean of its point's values (NaN: none)
    let y: Vec<f64> = design
        .rows
        .iter()
        .map(|l| {
            let (sum, n) =
                points[l.as_str()].iter().flatten().fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
            if n == 0 { f64::NAN } else { sum / n as f64 }
        })
        .collect();
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
            let n = design.size;
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
            a.indices = Some(Indices::Sobol(idx));
        }
        SweepKind::Morris => {
            let per = d + 1;
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
            a.indices = Some(Indices::Morris(s));
        }
        _ => unreachable!("only design groups are analysed"),
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-parameter Saltelli design whose "runs" compute y = 4 x₁ + x₂ + noise(replicate):
    /// S1 ≈ ST ≈ 16/17 and 1/17, the world's share is what the replicate offsets make it, and a
    /// failed run drops exactly its sample.
    #[test]
    fn sobol_group_from_runs() {
        use crate::store::RunRow;
        let n = 64;
        let unit = crate::stats::sensitivity::Saltelli::new(n, 2, 9);
        let rows: Vec<Vec<f64>> =
            unit.a.iter().chain(&unit.b).chain(unit.ab.iter().flatten()).cloned().collect();
        let labels: Vec<String> = (0..rows.len()).map(|i| format!("p{i}")).collect();
        let design = DesignRecord {
            size: n,
            rows: labels.clone(),
            moved: Vec::new(),
            unit: Vec::new(),
            delta: None,
        };
        let mut runs = Vec::new();
        for (i, x) in rows.iter().enumerate() {
            for rep in 0..3u32 {
                let failed = i == 5 && rep == 0;
                runs.push(RunRow {
                    study: "s".into(),
                    run_id: format!("{i}-{rep}"),
                    map: "m".into(),
                    algorithm: "odometry".into(),
                    point: labels[i].clone(),
                    replicate: rep,
                    world_seed: 0,
                    filter_seed: 0,
                    status: if failed { RunStatus::Failed } else { RunStatus::Ok },
                    error: None,
                    run_hash: String::new(),
                    params_hash: String::new(),
                    code_version: String::new(),
                    params: Vec::new(),
                    metrics: if failed {
                        Vec::new()
                    } else {
                        vec![("y".into(), 4.0 * x[0] + x[1] + 0.1 * rep as f64)]
                    },
                });
            }
        }
        let refs: Vec<&RunRow> = runs.iter().collect();
        let by_point =
            |p: &str| -> Vec<&RunRow> { refs.iter().copied().filter(|r| r.point == p).collect() };
        let cells: HashMap<String, Vec<&RunRow>> =
            labels.iter().map(|l| (l.clone(), by_point(l))).collect();
        let a = one(
            0,
            SweepKind::Sobol,
            &["a".into(), "b".into()],
            &design,
            |p| cells.get(p).map(Vec::as_slice).unwrap_or_default(),
            "m",
            "odometry",
            "y",
            false,
            3,
            1,
        );
        let Some(Indices::Sobol(x)) = &a.indices else { panic!("{}", a.note) };
        let (s1, st) = (&x.s1, &x.st);
        assert!(
            (s1[0].value - 16.0 / 17.0).abs() < 0.08 && (st[0].value - 16.0 / 17.0).abs() < 0.05,
            "{s1:?} {st:?}"
        );
        assert!((st[1].value - 1.0 / 17.0).abs() < 0.02, "{st:?}");
        assert_eq!(
            (a.runs, a.failed, a.used),
            (rows.len() * 3, 1, n),
            "a failed replicate leaves its point averaged over the other two"
        );
        let shares = a.shares.unwrap();
        assert!(
            shares.world > 0.0 && shares.residual < 1e-12,
            "additive replicate offsets are the world's share: {shares:?}"
        );
    }
}
