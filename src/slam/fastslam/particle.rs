//! A FastSLAM particle: a pose hypothesis and its own landmark map — one 2 × 2 EKF per landmark
//! ([FT] Eq. 3.7). Maps are shared copy-on-write between particles (`Arc`): resampling copies
//! pointers, and a particle copies a map only when it changes a map it shares.

use super::models::Model;
use crate::geom::Pose2;
use nalgebra::{Matrix2, Vector2};
use std::sync::Arc;

/// One landmark's Gaussian estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    pub mean: Vector2<f64>,
    pub cov: Matrix2<f64>,
    /// (sin, cos) of `mean[1]`, kept for line landmarks (their θ), so that predictions need no
    /// trigonometry; refresh with [`Landmark::refresh`] after changing the mean.
    pub trig: (f64, f64),
    /// The true landmark it was created from, under known association.
    pub id: Option<usize>,
}

impl Landmark {
    pub fn new(mean: Vector2<f64>, cov: Matrix2<f64>) -> Self {
        Self { mean, cov, trig: mean[1].sin_cos(), id: None }
    }

    pub fn refresh(&mut self) {
        self.trig = self.mean[1].sin_cos();
    }

    /// The predicted measurement of this landmark from `pose`.
    pub fn predict(&self, model: Model, pose: &Pose2) -> super::models::Prediction {
        match model {
            Model::Line => super::models::line_predict_trig(&self.mean, self.trig, pose),
            Model::Point => super::models::point_predict(&self.mean, pose),
        }
    }
}

/// A particle's map: lines and corners kept apart (association only compares like with like).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Map {
    pub lines: Vec<Landmark>,
    pub corners: Vec<Landmark>,
}

impl Map {
    pub fn of(&self, model: Model) -> &[Landmark] {
        match model {
            Model::Line => &self.lines,
            Model::Point => &self.corners,
        }
    }
    pub fn of_mut(&mut self, model: Model) -> &mut Vec<Landmark> {
        match model {
            Model::Line => &mut self.lines,
            Model::Point => &mut self.corners,
        }
    }
    pub fn len(&self) -> usize {
        self.lines.len() + self.corners.len()
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[derive(Debug, Clone)]
pub struct Particle {
    pub pose: Pose2,
    /// log of the importance weight, accumulated multiplicatively across steps ([FT] Table 6.3
    /// line 13) — logs so that long products of small likelihoods do not underflow.
    pub log_weight: f64,
    pub map: Arc<Map>,
}

impl Particle {
    pub fn new(pose: Pose2) -> Self {
        Self { pose, log_weight: 0.0, map: Arc::new(Map::default()) }
    }

    /// The map for writing: copied first if another particle shares it.
    pub fn map_mut(&mut self) -> &mut Map {
        Arc::make_mut(&mut self.map)
    }
}

/// Normalised weights from the particles' log weights, max-shifted (the largest becomes 1 before
/// normalising, which keeps the logs bounded). `None` when no weight is usable (all −∞, or a NaN):
/// the caller counts a numerical failure; the log weights are reset so that the filter can go on.
pub fn normalised_weights(particles: &mut [Particle]) -> Option<Vec<f64>> {
    let max = particles.iter().map(|p| p.log_weight).fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() || particles.iter().any(|p| p.log_weight.is_nan()) {
        for p in particles.iter_mut() {
            p.log_weight = 0.0;
        }
        return None;
    }
    for p in particles.iter_mut() {
        p.log_weight -= max; // ratios unchanged
    }
    let w: Vec<f64> = particles.iter().map(|p| p.log_weight.exp()).collect();
    let sum: f64 = w.iter().sum();
    Some(w.into_iter().map(|x| x / sum).collect())
}

/// The particles drawn from `ancestors` with their weights reset (maps shared, not copied), and
/// where the particle `best` went: systematic resampling keeps ≥ 1 copy of any w ≥ 1/M.
pub fn resampled(particles: &[Particle], ancestors: &[usize], best: usize) -> (Vec<Particle>, usize) {
    let best = ancestors.iter().position(|&a| a == best).unwrap_or(0);
    (ancestors.iter().map(|&a| Particle { log_weight: 0.0, ..particles[a].clone() }).collect(), best)
}

/// Index of the largest weight (the first on ties).
pub fn argmax(w: &[f64]) -> usize {
    w.iter().enumerate().fold(0, |best, (i, &x)| if x > w[best] { i } else { best })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampled_copies_share_their_map_until_one_writes() {
        let mut a = Particle::new(Pose2::IDENTITY);
        a.map_mut().lines.push(Landmark::new(Vector2::new(1.0, 0.0), Matrix2::identity()));
        let mut b = a.clone();
        assert!(Arc::ptr_eq(&a.map, &b.map), "a copy shares the map");
        b.map_mut().lines[0].mean[0] = 2.0;
        assert!(!Arc::ptr_eq(&a.map, &b.map));
        assert_eq!(a.map.lines[0].mean[0], 1.0, "the original is untouched");
    }
}
