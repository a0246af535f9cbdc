//! Run metrics: (World, Trace) → named numbers. Trajectory error follows evo's APE definition
//! (translation part, no alignment: both trajectories start at the same pose), with evo's names
//! (rmse, mean, median, max).

use crate::geom::{wrap_angle, Pose2};
use crate::slam::Trace;
use crate::world::World;

/// Bump when a metric's definition changes (part of every run's content hash).
pub const METRICS_VERSION: &str = "metrics-1";

/// A metric's documentation, shown in reports and the README.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricDef {
    pub name: &'static str,
    pub title: &'static str,
    pub unit: &'static str,
    pub description: &'static str,
    pub lower_is_better: bool,
}

pub const ATE_RMSE: &str = "ate_rmse_m";

/// Every metric the pipeline can produce, in display order.
pub const METRICS: &[MetricDef] = &[
    MetricDef { name: ATE_RMSE, title: "ATE RMSE", unit: "m", description: "root mean square of the position error over all steps (evo APE, translation, no alignment)", lower_is_better: true },
    MetricDef { name: "ate_mean_m", title: "ATE mean", unit: "m", description: "mean position error over all steps", lower_is_better: true },
    MetricDef { name: "ate_median_m", title: "ATE median", unit: "m", description: "median position error over all steps", lower_is_better: true },
    MetricDef { name: "ate_max_m", title: "ATE max", unit: "m", description: "largest position error over all steps", lower_is_better: true },
    MetricDef { name: "final_position_error_m", title: "Final position error", unit: "m", description: "position error at the last step", lower_is_better: true },
    MetricDef { name: "final_heading_error_deg", title: "Final heading error", unit: "deg", description: "absolute heading error at the last step, wrapped to [0, 180]", lower_is_better: true },
    MetricDef { name: "path_length_m", title: "Path length", unit: "m", description: "length of the true trajectory", lower_is_better: false },
    MetricDef { name: "numerical_failures", title: "Numerical failures", unit: "count", description: "numerical problems the algorithm met and survived", lower_is_better: true },
];

pub fn metric_def(name: &str) -> Option<&'static MetricDef> {
    METRICS.iter().find(|m| m.name == name)
}

/// Named metric values of one run, in [`METRICS`] order.
pub type RunMetrics = Vec<(&'static str, f64)>;

/// Computes every metric that applies to this run.
pub fn compute(world: &World, trace: &Trace) -> RunMetrics {
    let mut out = trajectory_metrics(&world.truth, &trace.estimate);
    out.push(("numerical_failures", trace.numerical_failures as f64));
    out
}

/// ATE statistics, final errors and path length. Pairs poses by step index; a shorter estimate is
/// a bug upstream, so the pairing stops at the shorter one and `final_*` use the last pair.
pub fn trajectory_metrics(truth: &[Pose2], estimate: &[Pose2]) -> RunMetrics {
    let errors: Vec<f64> = truth.iter().zip(estimate).map(|(t, e)| t.position().distance(e.position())).collect();
    let n = errors.len() as f64;
    let rmse = (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    let mean = errors.iter().sum::<f64>() / n;
    let max = errors.iter().copied().fold(f64::NAN, f64::max);
    let (final_pos, final_heading) = match (truth.get(errors.len().wrapping_sub(1)), estimate.get(errors.len().wrapping_sub(1))) {
        (Some(t), Some(e)) => (t.position().distance(e.position()), wrap_angle(t.theta - e.theta).abs().to_degrees()),
        _ => (f64::NAN, f64::NAN),
    };
    let path_length = truth.windows(2).map(|w| w[0].position().distance(w[1].position())).sum();
    vec![
        (ATE_RMSE, rmse),
        ("ate_mean_m", mean),
        ("ate_median_m", median(&errors)),
        ("ate_max_m", max),
        ("final_position_error_m", final_pos),
        ("final_heading_error_deg", final_heading),
        ("path_length_m", path_length),
    ]
}

/// Median (mean of the two middle values for an even count); NaN when empty or any value is NaN.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() || values.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(m: &RunMetrics, name: &str) -> f64 {
        m.iter().find(|(n, _)| *n == name).unwrap().1
    }

    #[test]
    fn identical_trajectories_have_zero_error() {
        let t: Vec<Pose2> = (0..10).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
        let m = trajectory_metrics(&t, &t);
        assert_eq!(get(&m, ATE_RMSE), 0.0);
        assert_eq!(get(&m, "final_heading_error_deg"), 0.0);
        assert_eq!(get(&m, "path_length_m"), 9.0);
    }

    #[test]
    fn ate_statistics_of_known_errors() {
        // position errors 0, 3, 4 (a 3-4-5 offset at the end)
        let truth = vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 0.0, 0.0), Pose2::new(2.0, 0.0, 3.0)];
        let est = vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 3.0, 0.0), Pose2::new(2.0, 4.0, -3.0)];
        let m = trajectory_metrics(&truth, &est);
        assert!((get(&m, ATE_RMSE) - (25.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((get(&m, "ate_mean_m") - 7.0 / 3.0).abs() < 1e-12);
        assert_eq!(get(&m, "ate_median_m"), 3.0);
        assert_eq!(get(&m, "ate_max_m"), 4.0);
        assert_eq!(get(&m, "final_position_error_m"), 4.0);
        // heading 3 vs −3 rad differ by 6 rad ≡ 2π − 6 ≈ 0.283 rad after wrapping
        assert!((get(&m, "final_heading_error_deg") - (2.0 * std::f64::consts::PI - 6.0).to_degrees()).abs() < 1e-9);
    }

    #[test]
    fn every_computed_metric_is_documented() {
        let truth = vec![Pose2::IDENTITY; 3];
        let m = trajectory_metrics(&truth, &truth);
        for (name, _) in m {
            assert!(metric_def(name).is_some(), "{name} undocumented");
        }
    }
}
