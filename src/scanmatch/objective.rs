//! The common objective ([EP] §5.1–5.2, Eq. 1–4): (reference [`PolarScan`], current [`PolarScan`],
//! candidate pose) → f [cm²], the one cost every matcher is scored by (PSM, E-PSM, NLopt, brute
//! force), so that [EP] Table 3's comparison on f is like for like.
//!
//! For every candidate pose, from scratch ([EP] L151: V depends on the pose):
//! 1. project every current point into the reference frame (Eq. 1–2);
//! 2. interpolate the projected current scan at the reference bearings, only between consecutive
//!    points of the same non-zero segment ([EP] L142; Diosi's `pm_scan_project`), skipping pairs
//!    that span ≥ π;
//! 3. z-buffer: where several values land on one bearing, the smallest range wins ([EP] L143,
//!    occlusion rule 1);
//! 4. drop invalid reference beams, and reference points that the current pose cannot see,
//!    x^c < 0 in the current frame (Eq. 3, occlusion rule 2, for a 180° front scanner);
//! 5. f = mean over the valid set V of (r_ref − r̂_cur)² (Eq. 4), in cm².
//!
//! **Why cm² and a mean** (the normalisation of Eq. 4 is lost in the source text): [EP] reports
//! f < 1 for a near-perfect alignment with ≈ 1 mm / 0.1° errors (Fig 24), f ≈ 37 → < 5 within one
//! match (Fig 27) and table means of 1–60, 20–45 at σ = 20 mm. A 0.1° error at 3–8 m is a 5–14 mm
//! range residual, i.e. 0.25–2 cm² squared — consistent with f < 1 as a mean of squared *cm*; in mm²
//! it would be 25–200, and a sum over ~150 pairs would be 150× larger still. σ = 20 mm at 1 m gives
//! residuals of 2–16 cm at 1–8 m, whose mean square (two noisy scans, partly filtered) is tens of cm²
//! — again the table's magnitude. Diosi's PSM code, on which [EP] builds, also works in cm. The
//! `sum` normalisation is kept as an option for completeness.
//!
//! Evaluation is allocation-free: the scratch buffers live in [`Objective`].

use super::Cost;
use super::scan::PolarScan;
use crate::config::{Checks, Violation};
use crate::geom::Pose2;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// m² → cm² (f is reported in cm², see the module doc).
pub const M2_TO_CM2: f64 = 1.0e4;

/// Slack [in beam steps] when mapping a projected bearing interval to reference-beam indices, so
/// that a projected point landing exactly on a reference bearing (e.g. the identity pose) is not
/// lost to rounding; allows at most 1e-9 beam of extrapolation.
const INDEX_SLACK_BEAMS: f64 = 1e-9;

/// How f is normalised over the valid set V (Eq. 4; the normalisation is lost in [EP]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Normalisation {
    /// f = (1/|V|) Σ e² [cm²] (default, see the module doc).
    Mean,
    /// f = Σ e² [cm²].
    Sum,
}

/// How the projected current scan is interpolated at a reference bearing φ_j between two
/// consecutive projected points a, b of one segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Linear in bearing: r̂ = r_a + (r_b − r_a)(φ_j − φ_a)/(φ_b − φ_a) ([EP] L142, Diosi's
    /// `pm_scan_project`). Not exact on a straight wall: r(φ) = ρ / cos(φ − α) is curved, so a
    /// noise-free pair at the true pose keeps f ≈ 1e-4–1e-2 cm² at 1° beams unless the projected
    /// bearings coincide with the reference ones.
    Linear,
    /// The range where the reference ray meets the chord a–b (exact on straight walls; an
    /// extension, not in [EP] or PSM).
    Chord,
}

/// Parameters of the objective (TOML table `objective`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ObjectiveParams {
    /// Minimum number of valid pairs |V|; below it f = +∞, so no search can "win" by discarding
    /// everything. Default 40: PSM's PM_MIN_VALID_POINTS for a 181-beam LMS200 ([EP] §3.4 advice).
    pub min_pairs: usize,
    /// Apply the occlusion rule of Eq. 3 (drop reference points with x^c < 0 in the current frame).
    /// Default true ([EP] L143–147).
    pub occlusion_rule: bool,
    /// Mean (default) or sum of the squared residuals.
    pub normalisation: Normalisation,
    /// Interpolation at the reference bearings. Default `linear` ([EP], PSM).
    pub interpolation: Interpolation,
    /// Gate on |r_ref − r̂_cur| [m]; pairs beyond it leave V. Default 1 m: PSM's PM_MAX_ERROR
    /// (100 cm), which E-PSM inherits from the code it extends — [EP] names no gate. Without it,
    /// occlusions that Eq. 3 misses (a near object moving against the background: the z-buffer
    /// keeps the object where the reference saw the wall 5 m behind it) dominate f: on
    /// `ep_rect_column` a noise-free pair scored f ≈ 1 800 cm² at the true pose and 12 cm² at a
    /// pose 5 cm off, so every search was pulled away from the truth. A very large value (say
    /// 1e9) restores the ungated objective.
    pub max_residual_m: Option<f64>,
}

impl Default for ObjectiveParams {
    fn default() -> Self {
        Self {
            min_pairs: 40,
            occlusion_rule: true,
            normalisation: Normalisation::Mean,
            interpolation: Interpolation::Linear,
            max_residual_m: Some(1.0),
        }
    }
}

impl ObjectiveParams {
    /// The report's sentence on f (Eq. 4) with these settings: normalisation, interpolation,
    /// occlusion rule, residual gate and minimum pairs.
    pub fn describe(&self) -> String {
        format!(
            "Objective f ([EP] Eq. 4, its normalisation lost in the source): the {} of the squared range residuals r_ref − r̂_cur in cm² over the valid pairs — current points projected into the reference frame (Eq. 1–2), interpolated {} between consecutive points of one segment, the nearest kept per bearing (z-buffer), reference points behind the current pose dropped (Eq. 3{}), pairs with |residual| > {} dropped (PSM's PM_MAX_ERROR), and f = ∞ below {} pairs. The cm² reading fits [EP]'s magnitudes (f < 1 at 1 mm / 0.1° errors, 20–45 at σ = 20 mm). Every matcher is scored by this f.",
            match self.normalisation {
                Normalisation::Mean => "mean",
                Normalisation::Sum => "sum",
            },
            match self.interpolation {
                Interpolation::Linear => "linearly in bearing",
                Interpolation::Chord => "on the chord",
            },
            if self.occlusion_rule { "" } else { ": off" },
            self.max_residual_m.map_or("∞".to_string(), |g| format!("{g} m")),
            self.min_pairs
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.require(self.min_pairs >= 1, "min_pairs", || "must be ≥ 1".to_string());
        if let Some(g) = self.max_residual_m {
            c.positive("max_residual_m", g);
        }
        c.finish()
    }
}

/// What became of one reference beam at a candidate pose ([EP] Fig 5's point categories).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PairStatus {
    /// In V (a cross in Fig 5).
    Valid,
    /// The reference beam is invalid (no return, out of range, or dropped by the segmenter).
    InvalidReference,
    /// No interpolated current range at this bearing.
    NoCorrespondence,
    /// Dropped by Eq. 3: not visible from the current pose (an inverted triangle in Fig 5).
    Occluded,
    /// Dropped by `max_residual_m`.
    ResidualGate,
}

/// Projection of a current scan into the reference frame and its interpolation at the reference
/// bearings with a min-range z-buffer (Eq. 1–2, [EP] §5.2 rule 1, Diosi's `pm_scan_project`).
/// Used by [`Objective`] (PSM has its own, [`super::psm`]). Allocation-free after construction.
#[derive(Debug, Clone)]
pub(crate) struct Projection {
    /// cos, sin of the current bearings φ_{c,i}.
    cur_cos: Vec<f64>,
    cur_sin: Vec<f64>,
    /// Reference bearings φ_{r,j} and their cos, sin.
    ref_phi: Vec<f64>,
    ref_cos: Vec<f64>,
    ref_sin: Vec<f64>,
    ref_angle_min_rad: f64,
    /// 1 / reference bearing step [1/rad].
    ref_inv_increment: f64,
    /// atan(k/32), k = 0..=32, for [`fast_atan2`].
    atan_table: [f64; ATAN_NODES + 1],
    /// Projected current points: Cartesian (reference frame), r'_{c,i}, φ'_{c,i}.
    px: Vec<f64>,
    py: Vec<f64>,
    pr: Vec<f64>,
    pphi: Vec<f64>,
    /// r̂_{c,j} per reference beam [m]; +∞ = no value ("empty").
    pub(crate) interpolated: Vec<f64>,
}

impl Projection {
    pub(crate) fn new(reference: &PolarScan, current: &PolarScan) -> Self {
        let n_cur = current.len();
        let n_ref = reference.len();
        let cur_phi: Vec<f64> = (0..n_cur).map(|i| current.bearing(i)).collect();
        let ref_phi: Vec<f64> = (0..n_ref).map(|j| reference.bearing(j)).collect();
        Self {
            cur_cos: cur_phi.iter().map(|p| p.cos()).collect(),
            cur_sin: cur_phi.iter().map(|p| p.sin()).collect(),
            ref_cos: ref_phi.iter().map(|p| p.cos()).collect(),
            ref_sin: ref_phi.iter().map(|p| p.sin()).collect(),
            ref_phi,
            ref_angle_min_rad: reference.angle_min_rad,
            ref_inv_increment: 1.0 / reference.angle_increment_rad,
            atan_table: atan_table(),
            px: vec![0.0; n_cur],
            py: vec![0.0; n_cur],
            pr: vec![0.0; n_cur],
            pphi: vec![0.0; n_cur],
            interpolated: vec![f64::INFINITY; n_ref],
        }
    }

    /// cos, sin of reference bearing j.
    #[inline]
    pub(crate) fn ref_cos_sin(&self, j: usize) -> (f64, f64) {
        (self.ref_cos[j], self.ref_sin[j])
    }

    /// Projects `current` (the scan given to [`Projection::new`]) at `pose` and fills
    /// `interpolated`. A non-finite pose leaves every bearing empty.
    pub(crate) fn project(
        &mut self,
        current: &PolarScan,
        pose: Pose2,
        interpolation: Interpolation,
    ) {
        self.interpolated.fill(f64::INFINITY);
        let n_ref = self.interpolated.len();
        if !pose.is_finite() || n_ref == 0 {
            return;
        }
        let (s, c) = pose.theta.sin_cos();
        // Eq. (1)–(2): every current point in the reference frame, polar. Branch-free passes over
        // all beams (invalid ones are computed and ignored) so that they pipeline/vectorise.
        let (tx, ty) = (pose.x, pose.y);
        for ((((x, y), &r), &cp), &sp) in self
            .px
            .iter_mut()
            .zip(self.py.iter_mut())
            .zip(&current.ranges)
            .zip(&self.cur_cos)
            .zip(&self.cur_sin)
        {
            // cos(θ_c + φ_i), sin(θ_c + φ_i) by the angle-sum identities (no trig per beam)
            *x = r * (cp * c - sp * s) + tx;
            *y = r * (sp * c + cp * s) + ty;
        }
        for ((r, &x), &y) in self.pr.iter_mut().zip(&self.px).zip(&self.py) {
            *r = (x * x + y * y).sqrt(); // Eq. (1)
        }
        let table = &self.atan_table;
        for ((phi, &x), &y) in self.pphi.iter_mut().zip(&self.px).zip(&self.py) {
            *phi = fast_atan2(y, x, table); // Eq. (2), in [−π, π]: the seam is behind the laser
        }
        let last_ref = (n_ref - 1) as f64;
        for i in 1..current.len() {
            let seg = current.segment[i];
            if seg == 0
                || seg != current.segment[i - 1]
                || !current.valid[i]
                || !current.valid[i - 1]
            {
                continue;
            }
            // (a bearing order reversed means a surface seen from behind: its values still hide
            // farther ones; Eq. 3 judges them in `Objective`)
            let (a, b) = if self.pphi[i] >= self.pphi[i - 1] { (i - 1, i) } else { (i, i - 1) };
            let (lo, hi) = (self.pphi[a], self.pphi[b]);
            if hi - lo >= PI || (hi - lo).is_nan() {
                continue; // spans the ±π seam (or a degenerate point)
            }
            // reference beams j with φ'_lo ≤ φ_j ≤ φ'_hi (in beam units, with a 1e-9 beam slack)
            let lo_idx = (lo - self.ref_angle_min_rad) * self.ref_inv_increment - INDEX_SLACK_BEAMS;
            let hi_idx = (hi - self.ref_angle_min_rad) * self.ref_inv_increment + INDEX_SLACK_BEAMS;
            if !(hi_idx >= 0.0 && lo_idx <= last_ref) {
                continue;
            }
            // ceil / floor of non-negative values by truncation (no libm calls)
            let lo_clamped = lo_idx.max(0.0);
            let j0 = lo_clamped as usize;
            let j0 = j0 + usize::from((j0 as f64) < lo_clamped);
            let j1 = hi_idx.min(last_ref) as usize; // j0 > j1: no reference bearing in between
            let (ra, rb) = (self.pr[a], self.pr[b]);
            let span = hi - lo;
            let slope = if span > 0.0 { (rb - ra) / span } else { 0.0 };
            let r_same_bearing = ra.min(rb);
            // cross(P_a, P_b) for the chord form: t·u_j = P_a + s(P_b − P_a) ⇒ t = (P_a × P_b)/(u_j × (P_b − P_a))
            let (ax, ay, bx, by) = (self.px[a], self.py[a], self.px[b], self.py[b]);
            let cross_ab = ax * by - ay * bx;
            for j in j0..=j1 {
                let linear =
                    if span > 0.0 { ra + slope * (self.ref_phi[j] - lo) } else { r_same_bearing };
                let r = match interpolation {
                    Interpolation::Linear => linear,
                    Interpolation::Chord => {
                        let t =
                            cross_ab / (self.ref_cos[j] * (by - ay) - self.ref_sin[j] * (bx - ax));
                        if t.is_finite() && t > 0.0 { t } else { linear }
                    }
                };
                // z-buffer: the closest surface wins ([EP] L143, occlusion rule 1)
                if r < self.interpolated[j] {
                    self.interpolated[j] = r;
                }
            }
        }
    }
}

/// Nodes of [`fast_atan2`]'s table over [0, 1].
const ATAN_NODES: usize = 32;

/// atan(k/ATAN_NODES), k = 0..=ATAN_NODES.
fn atan_table() -> [f64; ATAN_NODES + 1] {
    std::array::from_fn(|k| (k as f64 / ATAN_NODES as f64).atan())
}

/// atan2(y, x) in [−π, π] to within 1e-15 rad, branch-light (with libm's atan2 an evaluation of
/// 181 beams took ≈ 1.25× as long): octant reduction to t = min(|x|,|y|)/max(|x|,|y|) ∈ [0, 1], then
/// atan t = atan c + atan((t − c)/(1 + tc)) with c = k/32 the nearest node (|u| ≤ 1/64) and the odd
/// Taylor series of atan u to u⁷ (truncation < 1e-17). `table[k]` = atan(k/32). NaN at the origin
/// (0, 0), a degenerate point with no bearing; non-finite input gives an unspecified value (never
/// a panic) — the projection only feeds it finite points of consistent scans at finite poses.
#[inline(always)]
fn fast_atan2(y: f64, x: f64, table: &[f64; ATAN_NODES + 1]) -> f64 {
    use std::f64::consts::FRAC_PI_2;
    let (ax, ay) = (x.abs(), y.abs());
    let t = ax.min(ay) / ax.max(ay); // NaN at the origin
    let k = ((t * ATAN_NODES as f64 + 0.5) as usize).min(ATAN_NODES); // nearest node; NaN → 0
    let c = k as f64 / ATAN_NODES as f64;
    let u = (t - c) / (1.0 + t * c);
    let u2 = u * u;
    let series = u * (1.0 + u2 * (-1.0 / 3.0 + u2 * (1.0 / 5.0 + u2 * (-1.0 / 7.0))));
    let a = table[k] + series;
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x.is_sign_negative() { PI - a } else { a };
    a.copysign(y)
}

/// The objective f of Eq. 4 for one (reference, current) pair; implements [`Cost`].
#[derive(Debug, Clone)]
pub struct Objective<'a> {
    reference: &'a PolarScan,
    current: &'a PolarScan,
    params: ObjectiveParams,
    projection: Projection,
    /// A scan is internally inconsistent: every pose has no pairs.
    broken: bool,
    evaluations: u64,
}

impl<'a> Objective<'a> {
    /// The objective for `current` matched against `reference` (any beam geometries). An
    /// inconsistent scan (see [`PolarScan::is_consistent`]) yields f = +∞ everywhere.
    pub fn new(reference: &'a PolarScan, current: &'a PolarScan, params: &ObjectiveParams) -> Self {
        let broken = !reference.is_consistent() || !current.is_consistent();
        let empty = PolarScan {
            angle_min_rad: 0.0,
            angle_increment_rad: 1.0,
            ranges: vec![],
            valid: vec![],
            segment: vec![],
        };
        let projection = if broken {
            Projection::new(&empty, &empty)
        } else {
            Projection::new(reference, current)
        };
        Self { reference, current, params: params.clone(), projection, broken, evaluations: 0 }
    }

    pub fn reference(&self) -> &'a PolarScan {
        self.reference
    }

    pub fn current(&self) -> &'a PolarScan {
        self.current
    }

    pub fn params(&self) -> &ObjectiveParams {
        &self.params
    }

    /// f [cm²] and |V| at `pose` (one evaluation).
    pub fn f_and_pairs(&mut self, pose: Pose2) -> (f64, usize) {
        let (sum_sq, n) = self.pass(pose, |_, _, _| {});
        (self.finish(sum_sq, n), n)
    }

    /// Fig 5's categories at `pose`: `out[j]` for every reference beam (`out.len()` must be
    /// [`Cost::beams`]; extra entries are left alone). Returns |V|. Counts as one evaluation.
    pub fn classify(&mut self, pose: Pose2, out: &mut [PairStatus]) -> usize {
        self.pass(pose, |j, status, _| {
            if let Some(o) = out.get_mut(j) {
                *o = status;
            }
        })
        .1
    }

    /// r̂_{c,j} [m] from the last evaluation (+∞ = no correspondence).
    pub fn interpolated(&self) -> &[f64] {
        &self.projection.interpolated
    }

    fn finish(&self, sum_sq_m2: f64, n: usize) -> f64 {
        if n < self.params.min_pairs || n == 0 {
            return f64::INFINITY;
        }
        let total = sum_sq_m2 * M2_TO_CM2;
        match self.params.normalisation {
            Normalisation::Mean => total / n as f64,
            Normalisation::Sum => total,
        }
    }

    /// Projects, interpolates, discards; calls `visit(j, status, residual_m)` for every reference
    /// beam; returns (Σ e² [m²], |V|).
    #[inline]
    fn pass<F: FnMut(usize, PairStatus, f64)>(
        &mut self,
        pose: Pose2,
        mut visit: F,
    ) -> (f64, usize) {
        self.evaluations += 1;
        if self.broken {
            for j in 0..self.reference.len() {
                visit(j, PairStatus::InvalidReference, f64::NAN);
            }
            return (0.0, 0);
        }
        self.projection.project(self.current, pose, self.params.interpolation);
        let (s, c) = pose.theta.sin_cos();
        let gate = self.params.max_residual_m.unwrap_or(f64::INFINITY);
        let (mut sum_sq, mut n) = (0.0, 0usize);
        let reference = self.reference;
        for j in 0..reference.len() {
            if !reference.valid[j] {
                visit(j, PairStatus::InvalidReference, f64::NAN);
                continue;
            }
            let r_hat = self.projection.interpolated[j];
            if !r_hat.is_finite() {
                visit(j, PairStatus::NoCorrespondence, f64::NAN);
                continue;
            }
            let r_ref = reference.ranges[j];
            if self.params.occlusion_rule {
                let (cos_phi, sin_phi) = self.projection.ref_cos_sin(j);
                let x_c = (r_ref * cos_phi - pose.x) * c + (r_ref * sin_phi - pose.y) * s; // Eq. (3)
                if x_c < 0.0 {
                    visit(j, PairStatus::Occluded, f64::NAN);
                    continue;
                }
            }
            let e = r_ref - r_hat;
            if e.abs() > gate {
                visit(j, PairStatus::ResidualGate, f64::NAN);
                continue;
            }
            sum_sq += e * e; // Eq. (4)
            n += 1;
            visit(j, PairStatus::Valid, e);
        }
        (sum_sq, n)
    }
}

impl Cost for Objective<'_> {
    fn f(&mut self, pose: Pose2) -> f64 {
        self.f_and_pairs(pose).0
    }

    fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize {
        out.fill(f64::NAN);
        self.pass(pose, |j, _, e| {
            if let Some(o) = out.get_mut(j) {
                *o = e;
            }
        })
        .1
    }

    fn beams(&self) -> usize {
        self.reference.len()
    }

    fn evaluations(&self) -> u64 {
        self.evaluations
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scanmatch::scan::testing::*;

    fn deg(d: f64) -> f64 {
        d.to_radians()
    }

    #[test]
    fn describe_names_normalisation_gate_and_min_pairs() {
        let s = ObjectiveParams {
            normalisation: Normalisation::Sum,
            max_residual_m: Some(0.5),
            min_pairs: 25,
            ..ObjectiveParams::default()
        }
        .describe();
        assert!(
            s.contains("the sum of the squared range residuals")
                && s.contains("|residual| > 0.5 m dropped")
                && s.contains("f = ∞ below 25 pairs"),
            "{s}"
        );
        let s = ObjectiveParams {
            occlusion_rule: false,
            max_residual_m: None,
            ..ObjectiveParams::default()
        }
        .describe();
        assert!(s.contains("(Eq. 3: off)") && s.contains("|residual| > ∞ dropped"), "{s}");
    }

    #[test]
    fn fast_atan2_matches_libm() {
        let table = atan_table();
        let mut worst: f64 = 0.0;
        for i in 0..20_000 {
            let a = -PI + (i as f64 + 0.5) * (2.0 * PI / 20_000.0);
            for r in [1e-3, 0.7, 3.0, 9.9] {
                let (y, x) = (r * a.sin(), r * a.cos());
                worst = worst.max((fast_atan2(y, x, &table) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 1e-15, "max error {worst}");
        for (y, x) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (-0.0, -1.0),
            (1e-300, 2.0),
        ] {
            assert!((fast_atan2(y, x, &table) - f64::atan2(y, x)).abs() < 1e-15, "({y}, {x})");
        }
        let _ = (fast_atan2(f64::NAN, 1.0, &table), fast_atan2(1.0, f64::INFINITY, &table)); // no panic
        assert!(fast_atan2(0.0, 0.0, &table).is_nan());
    }

    #[test]
    fn zero_at_the_true_pose_when_bearings_coincide() {
        // a pure rotation by whole beams: projected bearings land on reference bearings exactly,
        // so linear interpolation is exact
        for delta in
            [Pose2::IDENTITY, Pose2::new(0.0, 0.0, deg(3.0)), Pose2::new(0.0, 0.0, deg(-7.0))]
        {
            let (r, c) = room_pair(delta);
            let mut obj = Objective::new(&r, &c, &ObjectiveParams::default());
            let (f, n) = obj.f_and_pairs(delta);
            assert!(f.abs() < 1e-12, "{delta:?}: f = {f}");
            assert!(n > 150, "{delta:?}: pairs {n}");
        }
    }

    #[test]
    fn zero_at_a_general_true_pose_with_chord_interpolation_small_with_linear() {
        let delta = Pose2::new(0.2, -0.1, deg(3.0));
        let (r, c) = room_pair(delta);
        let chord = ObjectiveParams { interpolation: Interpolation::Chord, ..Default::default() };
        let (f, n) = Objective::new(&r, &c, &chord).f_and_pairs(delta);
        assert!(f.abs() < 1e-12 && n > 120, "chord: f = {f}, n = {n}");
        // linear interpolation in bearing leaves a small bias (r(φ) is curved on a straight wall)
        let (f, _) = Objective::new(&r, &c, &ObjectiveParams::default()).f_and_pairs(delta);
        assert!(f > 0.0 && f < 1e-2, "linear: f = {f}");
    }

    #[test]
    fn grows_away_from_the_true_pose() {
        // the plain rectangle: no occlusion boundary, whose crossing would make single pairs jump
        // by metres (the piecewise behaviour of [EP] Figs 33–34 — tested in the z-buffer test)
        let delta = Pose2::new(0.2, -0.1, deg(3.0));
        let beams = Beams::lms200();
        let walls = polygon(&[(0.0, 0.0), (10.0, 0.0), (10.0, 5.0), (0.0, 5.0)]);
        let (raw_r, raw_c) = raw_pair(&walls, ROOM_REFERENCE_POSE, delta, &beams);
        let prep = |raw: &[Option<f64>]| {
            PolarScan::contiguous(
                raw,
                beams.angle_min_rad,
                beams.angle_increment_rad,
                MAX_RANGE_M,
                JUMP_M,
            )
        };
        let (r, c) = (prep(&raw_r), prep(&raw_c));
        let mut obj = Objective::new(&r, &c, &ObjectiveParams::default());
        let f0 = obj.f(delta);
        let mut prev = [f0; 3];
        for k in 1..=5 {
            let s = k as f64;
            let moved = [
                Pose2::new(delta.x + 0.01 * s, delta.y, delta.theta),
                Pose2::new(delta.x, delta.y - 0.01 * s, delta.theta),
                Pose2::new(delta.x, delta.y, delta.theta + deg(0.2 * s)),
            ];
            for (axis, p) in moved.into_iter().enumerate() {
                let f = obj.f(p);
                assert!(f > prev[axis], "axis {axis}, step {k}: {f} ≤ {}", prev[axis]);
                prev[axis] = f;
            }
        }
        // 1 cm off in x: residuals ≈ 1 cm on most beams → f of order 1 cm²
        let f = obj.f(Pose2::new(delta.x + 0.01, delta.y, delta.theta));
        assert!(f > 0.1 && f < 2.0, "f = {f}");
        assert_eq!(obj.evaluations(), 1 + 15 + 1);
    }

    /// Two walls: a short one at x = 1 (|y| ≤ 0.3) and a long one at x = 4. The current laser sits
    /// at (2, 0) looking along +x, so the short wall is behind it: the current scan sees only the
    /// long wall, whose projection covers the bearings where the reference sees the short wall.
    /// Eq. 3 (x^c = 1 − 2 < 0) must drop exactly those reference points.
    #[test]
    fn occlusion_rule_drops_reference_points_behind_the_current_pose() {
        use crate::geom::{Point2, Segment};
        let walls = [
            Segment::new(Point2::new(1.0, -0.3), Point2::new(1.0, 0.3)),
            Segment::new(Point2::new(4.0, -8.0), Point2::new(4.0, 8.0)),
        ];
        let beams = Beams { angle_min_rad: deg(-60.0), angle_increment_rad: deg(1.0), count: 121 };
        let truth = Pose2::new(2.0, 0.0, 0.0);
        let (raw_ref, raw_cur) = raw_pair(&walls, Pose2::IDENTITY, truth, &beams);
        let prep = |raw: &[Option<f64>]| {
            PolarScan::contiguous(
                raw,
                beams.angle_min_rad,
                beams.angle_increment_rad,
                MAX_RANGE_M,
                JUMP_M,
            )
        };
        let (reference, current) = (prep(&raw_ref), prep(&raw_cur));
        // ungated, so that the rule alone decides
        let on = ObjectiveParams {
            interpolation: Interpolation::Chord,
            max_residual_m: None,
            ..Default::default()
        };
        let mut obj = Objective::new(&reference, &current, &on);
        let mut statuses = vec![PairStatus::Valid; reference.len()];
        let n = obj.classify(truth, &mut statuses);
        let mut occluded = 0;
        for (j, st) in statuses.iter().enumerate() {
            let x_ref = reference.ranges[j] * reference.bearing(j).cos();
            let behind = reference.valid[j] && x_ref < truth.x;
            if behind {
                occluded += 1;
                assert_eq!(*st, PairStatus::Occluded, "beam {j}: x = {x_ref}");
            } else {
                assert_ne!(*st, PairStatus::Occluded, "beam {j}");
            }
        }
        assert!(occluded >= 30, "the short wall covers ±16.7°: {occluded}");
        assert!(obj.f(truth).abs() < 1e-12 && n >= 40);
        // rule off: the short-wall beams pair with the long wall (3 m residuals)
        let off = ObjectiveParams { occlusion_rule: false, ..on };
        let mut obj = Objective::new(&reference, &current, &off);
        assert_eq!(obj.classify(truth, &mut statuses), n + occluded);
        assert!(!statuses.contains(&PairStatus::Occluded));
        assert!(obj.f(truth) > 1e4, "f = {}", obj.f(truth));
    }

    /// The z-buffer equals a brute-force minimum over every same-segment pair covering a bearing,
    /// on room pairs whose parallax around the column makes surfaces overlap after projection.
    #[test]
    fn z_buffer_keeps_the_nearest_surface() {
        let mut overlaps = 0;
        for delta in [
            Pose2::new(0.0, 0.6, deg(2.0)),
            Pose2::new(0.8, -0.5, deg(-5.0)),
            Pose2::new(1.5, 0.9, deg(10.0)),
        ] {
            let (r, c) = room_pair(delta);
            let mut p = Projection::new(&r, &c);
            p.project(&c, delta, Interpolation::Linear);
            // brute force: every covering pair's value, in plain trigonometry
            let pts: Vec<Option<(f64, f64)>> = (0..c.len())
                .map(|i| {
                    (c.valid[i] && c.segment[i] != 0).then(|| {
                        let a = delta.theta + c.bearing(i);
                        let (x, y) =
                            (c.ranges[i] * a.cos() + delta.x, c.ranges[i] * a.sin() + delta.y);
                        (x.hypot(y), y.atan2(x))
                    })
                })
                .collect();
            for j in 0..r.len() {
                let phi = r.bearing(j);
                let mut values = vec![];
                for i in 1..c.len() {
                    if c.segment[i] == 0 || c.segment[i] != c.segment[i - 1] {
                        continue;
                    }
                    let (Some((r0, p0)), Some((r1, p1))) = (pts[i - 1], pts[i]) else { continue };
                    let ((ra, pa), (rb, pb)) =
                        if p1 >= p0 { ((r0, p0), (r1, p1)) } else { ((r1, p1), (r0, p0)) };
                    if pb - pa < PI && phi >= pa - 1e-9 && phi <= pb + 1e-9 {
                        values.push(if pb > pa {
                            ra + (rb - ra) * (phi - pa) / (pb - pa)
                        } else {
                            ra.min(rb)
                        });
                    }
                }
                let best = values.iter().copied().fold(f64::INFINITY, f64::min);
                let worst = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                if values.len() >= 2 && worst - best > 0.1 {
                    overlaps += 1;
                }
                let got = p.interpolated[j];
                assert!(
                    got == best || (got - best).abs() < 1e-9,
                    "{delta:?} beam {j}: {got} vs {best}"
                );
            }
        }
        assert!(overlaps > 0, "the scenes must contain overlapping surfaces");
    }

    #[test]
    fn too_few_pairs_give_infinity() {
        let delta = Pose2::new(0.2, -0.1, deg(3.0));
        let (r, c) = room_pair(delta);
        let mut obj =
            Objective::new(&r, &c, &ObjectiveParams { min_pairs: 1000, ..Default::default() });
        assert_eq!(obj.f(delta), f64::INFINITY);
        let mut res = vec![0.0; obj.beams()];
        let n = obj.residuals(delta, &mut res);
        assert!(n > 100 && n < 1000);
        assert_eq!(res.iter().filter(|e| e.is_finite()).count(), n);
        // a pose far outside the room: nothing overlaps
        let mut obj = Objective::new(&r, &c, &ObjectiveParams::default());
        assert_eq!(obj.f(Pose2::new(50.0, 0.0, 0.0)), f64::INFINITY);
    }

    #[test]
    fn bad_data_degrades_to_too_few_pairs() {
        let delta = Pose2::new(0.2, -0.1, deg(3.0));
        let (r, mut c) = room_pair(delta);
        let params = ObjectiveParams::default();
        // NaN pose
        assert_eq!(
            Objective::new(&r, &c, &params).f(Pose2::new(f64::NAN, 0.0, 0.0)),
            f64::INFINITY
        );
        // empty scans
        let empty = PolarScan::contiguous(&[], -1.0, 0.01, 10.0, 0.2);
        assert_eq!(Objective::new(&empty, &c, &params).f(delta), f64::INFINITY);
        assert_eq!(Objective::new(&r, &empty, &params).f(delta), f64::INFINITY);
        // all-invalid
        let dead = PolarScan::contiguous(
            &vec![None; 181],
            r.angle_min_rad,
            r.angle_increment_rad,
            10.0,
            0.2,
        );
        assert_eq!(Objective::new(&r, &dead, &params).f(delta), f64::INFINITY);
        // NaN ranges on "valid" beams / inconsistent lengths: inconsistent scan, no panic
        c.ranges[10] = f64::NAN;
        assert_eq!(Objective::new(&r, &c, &params).f(delta), f64::INFINITY);
        c.ranges.pop();
        let mut obj = Objective::new(&r, &c, &params);
        let mut res = vec![0.0; obj.beams()];
        assert_eq!(obj.residuals(delta, &mut res), 0);
        assert!(res.iter().all(|e| e.is_nan()));
    }

    #[test]
    fn sum_normalisation_and_validation() {
        let delta = Pose2::new(0.0, 0.0, deg(3.0));
        let (r, c) = room_pair(delta);
        let off = Pose2::new(0.01, 0.0, delta.theta);
        let (mean, n) = Objective::new(&r, &c, &ObjectiveParams::default()).f_and_pairs(off);
        let sum = Objective::new(
            &r,
            &c,
            &ObjectiveParams { normalisation: Normalisation::Sum, ..Default::default() },
        )
        .f(off);
        assert!((sum - mean * n as f64).abs() < 1e-9 * sum);
        assert!(ObjectiveParams::default().validate().is_empty());
        let bad =
            ObjectiveParams { min_pairs: 0, max_residual_m: Some(-1.0), ..Default::default() };
        let keys: Vec<String> = bad.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["min_pairs", "max_residual_m"]);
        // the TOML table round-trips and rejects unknown keys
        let t: ObjectiveParams = toml::from_str(
            "normalisation = \"sum\"\ninterpolation = \"chord\"\nmax_residual_m = 0.5",
        )
        .unwrap();
        assert_eq!(t.normalisation, Normalisation::Sum);
        assert_eq!(t.max_residual_m, Some(0.5));
        assert!(toml::from_str::<ObjectiveParams>("min_pair = 3").is_err());
    }
}
