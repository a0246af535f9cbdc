//! Scan preprocessing: raw ranges (`&[Option<f64>]`, `None` = no return) → [`PolarScan`] (filtered
//! ranges, validity, segment labels). [EP] §3 step 1 / ch. 4; [EP] reference §3.1 lists the three
//! methods a reproduction must offer:
//!
//! - [`Segmentation::PsmHeuristics`]: Diosi's `pm_preprocessScan` exactly ([EP] §2.2a): median
//!   filter (window 5, indices clamped) → far points bad → segmentation by 20 cm range jumps with
//!   the linear-extrapolation rule and the lone-point/collinear rule; segment 0 = isolated point.
//! - [`Segmentation::Lines`]: the replacement for Cuadra's line extractor ([EP] ch. 4), which cannot
//!   be rebuilt from [EP]. Noise model σ(r) = k·r with k estimated from the scan (as Cuadra's) or
//!   given; split-and-merge with a noise-aware split test, weighted total-least-squares lines, a
//!   χ² merge test for adjacent collinear pieces, and ranges replaced by the beam/line
//!   intersection, so filtered ranges lie on lines ([EP] Figs 2, 36). Beams outside segments are
//!   invalid ([EP] L142). See [`LineParams`] for every threshold.
//! - [`Segmentation::None`]: raw ranges; one segment per contiguous run of valid readings (no jump
//!   test), single readings valid but in segment 0.

use super::real::{Precision, Real};
use super::scan::{PolarScan, usable_range};
use crate::config::{Checks, Violation};
use serde::{Deserialize, Serialize};

/// The preprocessing method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Segmentation {
    /// Line segmentation and filtering (E-PSM's choice of a line segmenter; our replacement for
    /// Cuadra's).
    Lines,
    /// Diosi's PSM heuristics ("Diosi Original" in [EP] Table 4).
    PsmHeuristics,
    /// Raw ranges, contiguous runs.
    None,
}

/// Preprocessing parameters (TOML table `seg`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SegmentationParams {
    /// Which preprocessing. Default `lines`: E-PSM replaces PSM's heuristics by a line segmenter
    /// ([EP] §3, Table 4).
    pub method: Segmentation,
    /// Parameters of `psm_heuristics`.
    pub psm_heuristics: PsmHeuristicsParams,
    /// Parameters of `lines`.
    pub lines: LineParams,
}

impl Default for SegmentationParams {
    fn default() -> Self {
        Self {
            method: Segmentation::Lines,
            psm_heuristics: PsmHeuristicsParams::default(),
            lines: LineParams::default(),
        }
    }
}

impl SegmentationParams {
    /// The report's sentence on the preprocessing: the method and the `lines` thresholds.
    pub fn describe(&self) -> String {
        format!(
            "Preprocessing ({}): [EP]'s Cuadra line segmentation cannot be rebuilt from the source, so `lines` is a noise-aware split-and-merge — runs split at range jumps, recursive splits at the point farthest from the chord while it lies more than {} σ off (σ = k·r, k estimated from the scan by a robust median), weighted line fits, adjacent collinear pieces merged by a χ² test at α = {}, pieces under {} points invalid — and every beam in a segment gets the range where its ray meets the fitted line. `psm_original` always uses PSM's own heuristics (median filter of 5, 20 cm jump segmentation).",
            match self.method {
                Segmentation::Lines => "lines",
                Segmentation::PsmHeuristics => "PSM's heuristics",
                Segmentation::None => "none",
            },
            self.lines.split_sigmas,
            self.lines.merge_alpha,
            self.lines.min_points
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.nested("psm_heuristics", self.psm_heuristics.validate());
        c.nested("lines", self.lines.validate());
        c.finish()
    }
}

/// Diosi's preprocessing constants ([EP] §2.2a, §2.2g; PSM `polar_match.cpp`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PsmHeuristicsParams {
    /// Median filter window [beams], odd. PSM: 5 (HALF_WINDOW = 2).
    pub median_window: usize,
    /// Range jump that breaks a segment [m]. PSM: MAX_DIST = PM_SEG_MAX_DIST = 20 cm.
    pub max_jump_m: f64,
    /// Arithmetic of the far-point and jump tests, on ranges in centimetres as v0.3 holds them.
    /// Default `single` (v0.3's `PM_TYPE float`): on a log with centimetre ranges an exact 20 cm
    /// jump breaks a segment there, where in double-precision metres 1.3 − 1.1 < 0.2 would not.
    /// `psm_original` runs its heuristics in PSM's own precision.
    pub precision: Precision,
}

impl Default for PsmHeuristicsParams {
    fn default() -> Self {
        Self { median_window: 5, max_jump_m: 0.20, precision: Precision::Single }
    }
}

impl PsmHeuristicsParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.require(self.median_window % 2 == 1, "median_window", || {
            format!("must be odd, got {}", self.median_window)
        });
        c.positive("max_jump_m", self.max_jump_m);
        c.finish()
    }
}

/// Line segmentation thresholds. [EP] gives none for Cuadra's method ([EP] reference §3.1), so each
/// is an assumption documented here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LineParams {
    /// Noise model σ(r) = k·r: k [dimensionless, m per m]. `None` (default): estimated per scan,
    /// as Cuadra's method does ([EP] L104, L116) — a robust MAD of each point's range deviation from
    /// the chord of its two neighbours (zero on a noise-free straight wall, variance 1.5 σ² under
    /// noise), so k̂ = median(|δᵢ|/rᵢ) / (0.6745·√1.5).
    pub noise_k: Option<f64>,
    /// Floor on σ [m]: range quantisation of typical lidars (1 mm); keeps the tests finite on
    /// noise-free scans.
    pub sigma_floor_m: f64,
    /// A range jump always breaks a run when |Δr| > this [m]. Default 0.20 m, PSM's PM_SEG_MAX_DIST.
    pub jump_m: f64,
    /// ...or when |Δr| > jump_sigmas·√2·σ(r) if that is larger (the difference of two noisy ranges
    /// has σ√2): 5 keeps false breaks below 1e-6 per beam pair. Pieces split by a jump are
    /// re-joined by the merge test when collinear (oblique walls).
    pub jump_sigmas: f64,
    /// Split test: a piece is one line while every point's orthogonal distance to its weighted TLS
    /// line is ≤ split_sigmas·σᵢ (σᵢ = max(k·rᵢ, floor) is the radial σ, an upper bound of the
    /// orthogonal one: conservative). Default 4: by Bonferroni, P(false split) ≤ 181·2(1 − Φ(4))
    /// ≈ 1 % for a whole 181-beam piece. Also the test for re-attaching a split point.
    pub split_sigmas: f64,
    /// Merge test of two adjacent pieces (a "test taken from classical regression theory", [EP]
    /// L117–122): the χ² test of one common line against two separate lines, ΔRSS =
    /// RSS(joint) − RSS(a) − RSS(b) (σ-weighted) ~ χ²(ν) with ν = 2 parameters under H0. Merge when
    /// ΔRSS ≤ χ²_ν(1 − merge_alpha) and the joint line passes the split test. Default α = 0.01.
    pub merge_alpha: f64,
    /// Largest gap of invalid beams [beams] that a merge may bridge (a dropped outlier or a missing
    /// return inside a wall). Default 1. Beams in the gap stay invalid.
    pub merge_gap_beams: usize,
    /// Minimum points of a segment; shorter pieces become invalid (segment 0). Default 4: ≥ 3 for a
    /// line fit with a residual, +1 margin; at 1° beams it keeps a 0.5 m column visible to ~7 m.
    pub min_points: usize,
}

impl Default for LineParams {
    fn default() -> Self {
        Self {
            noise_k: None,
            sigma_floor_m: 0.001,
            jump_m: 0.20,
            jump_sigmas: 5.0,
            split_sigmas: 4.0,
            merge_alpha: 0.01,
            merge_gap_beams: 1,
            min_points: 4,
        }
    }
}

impl LineParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        if let Some(k) = self.noise_k {
            c.non_negative("noise_k", k);
        }
        c.positive("sigma_floor_m", self.sigma_floor_m);
        c.positive("jump_m", self.jump_m);
        c.non_negative("jump_sigmas", self.jump_sigmas);
        c.positive("split_sigmas", self.split_sigmas);
        c.in_range("merge_alpha", self.merge_alpha, 1e-12, 0.5);
        c.require(self.min_points >= 2, "min_points", || {
            format!("must be ≥ 2, got {}", self.min_points)
        });
        c.finish()
    }
}

/// Prepares a raw scan for matching with the chosen method. Never panics: non-finite, non-positive
/// or beyond-`max_range_m` readings are simply invalid; an empty input gives an empty scan.
pub fn prepare(
    ranges: &[Option<f64>],
    angle_min_rad: f64,
    angle_increment_rad: f64,
    max_range_m: f64,
    params: &SegmentationParams,
) -> PolarScan {
    match params.method {
        Segmentation::None => PolarScan::contiguous(
            ranges,
            angle_min_rad,
            angle_increment_rad,
            max_range_m,
            f64::INFINITY,
        ),
        Segmentation::PsmHeuristics => psm_heuristics(
            ranges,
            angle_min_rad,
            angle_increment_rad,
            max_range_m,
            &params.psm_heuristics,
        ),
        Segmentation::Lines => {
            lines(ranges, angle_min_rad, angle_increment_rad, max_range_m, &params.lines)
        }
    }
}

// ---------------------------------------------------------------------------------------------
// PSM heuristics

/// Diosi's `pm_median_filter` → `pm_find_far_points` → `pm_segment_scan` ([EP] §2.2a), as
/// v0.3 computes them: the median filter works in place (a running median: each window sees the
/// already filtered ranges to its left), and the far-point and jump tests compare centimetres in
/// `params.precision`.
///
/// No-return, non-finite and non-positive readings enter as +∞ (PSM receives the scanner's
/// max-range value there), so the median sees them as far and they end up bad. Labels of bad beams
/// are cleared at the end (PSM may let a bad point carry the next segment's number; it is never
/// interpolated either way).
pub fn psm_heuristics(
    ranges: &[Option<f64>],
    angle_min_rad: f64,
    angle_increment_rad: f64,
    max_range_m: f64,
    params: &PsmHeuristicsParams,
) -> PolarScan {
    let n = ranges.len();
    let raw: Vec<f64> = ranges
        .iter()
        .map(|r| r.filter(|r| r.is_finite() && *r > 0.0).unwrap_or(f64::INFINITY))
        .collect();
    // 1. median filter, window 5, indices clamped at the scan ends, in place as v0.3 runs it:
    // beam i's window already holds the filtered values of beams i − 2 and i − 1
    let half = params.median_window / 2;
    let mut window = Vec::with_capacity(params.median_window.max(1));
    let mut r = raw;
    for i in 0..n {
        window.clear();
        window.extend(
            (0..params.median_window.max(1)).map(|k| r[(i + k).saturating_sub(half).min(n - 1)]),
        );
        window.sort_by(f64::total_cmp);
        r[i] = window[window.len() / 2];
    }
    // 2. far points are bad; 3. segmentation by range discontinuity (pm_segment_scan, line by
    // line): both on centimetres in PSM's precision
    let (bad, seg) = match params.precision {
        Precision::Single => psm_far_and_segment::<f32>(&r, max_range_m, params.max_jump_m),
        Precision::Double => psm_far_and_segment::<f64>(&r, max_range_m, params.max_jump_m),
    };
    let valid: Vec<bool> = bad.iter().map(|b| !b).collect();
    PolarScan {
        angle_min_rad,
        angle_increment_rad,
        ranges: r.iter().zip(&valid).map(|(&r, &v)| if v { r } else { 0.0 }).collect(),
        segment: seg.iter().zip(&valid).map(|(&s, &v)| if v { s } else { 0 }).collect(),
        valid,
    }
}

/// `pm_find_far_points` and `pm_segment_scan` on ranges [m] converted to centimetres in `T`:
/// (bad, segment labels).
fn psm_far_and_segment<T: Real>(
    r_m: &[f64],
    max_range_m: f64,
    max_jump_m: f64,
) -> (Vec<bool>, Vec<u32>) {
    const M_TO_CM: f64 = 100.0;
    let r: Vec<T> = r_m.iter().map(|&r| T::from_f64(r * M_TO_CM)).collect();
    let max_range = T::from_f64(max_range_m * M_TO_CM);
    let bad: Vec<bool> = r.iter().map(|&r| !(r <= max_range)).collect(); // NaN is bad too
    let seg = psm_segment(&r, &bad, T::from_f64(max_jump_m * M_TO_CM));
    (bad, seg)
}

/// `pm_segment_scan`: segment numbers from 1; 0 = a single isolated point. The extrapolation
/// r[i] − (2r[i−1] − r[i−2]) is a double expression in the C code, rounded to `T`.
fn psm_segment<T: Real>(r: &[T], bad: &[bool], max_dist: T) -> Vec<u32> {
    let extrapolation_error =
        |i: usize| T::from_f64(r[i].to_f64() - (2.0 * r[i - 1].to_f64() - r[i - 2].to_f64()));
    let n = r.len();
    let mut seg = vec![0u32; n];
    if n < 2 {
        return seg;
    }
    let mut seg_cnt = 1u32;
    let mut cnt;
    // init: are the first two points in the same segment?
    if (r[0] - r[1]).abs() < max_dist {
        seg[0] = seg_cnt;
        seg[1] = seg_cnt;
        cnt = 2;
    } else {
        seg[0] = 0;
        seg[1] = seg_cnt;
        cnt = 1;
    }
    for i in 2..n {
        let mut break_seg = false;
        if bad[i] {
            break_seg = true;
            seg[i] = 0;
        } else {
            let dr = extrapolation_error(i); // linear extrapolation
            if (r[i] - r[i - 1]).abs() < max_dist
                || (seg[i - 1] == seg[i - 2] && dr.abs() < max_dist)
            {
                cnt += 1;
                seg[i] = seg_cnt;
            } else {
                break_seg = true;
            }
        }
        if break_seg {
            if cnt == 1 {
                // are the last three on a line by coincidence?
                let dr = extrapolation_error(i);
                if seg[i - 2] == 0 && !bad[i] && !bad[i - 1] && !bad[i - 2] && dr.abs() < max_dist {
                    seg[i] = seg_cnt;
                    seg[i - 1] = seg_cnt;
                    seg[i - 2] = seg_cnt;
                    cnt = 3;
                } else {
                    seg[i - 1] = 0;
                    seg[i] = seg_cnt; // the current point starts a new segment
                    cnt = 1;
                }
            } else {
                seg_cnt += 1;
                seg[i] = seg_cnt;
                cnt = 1;
            }
        }
    }
    seg
}

// ---------------------------------------------------------------------------------------------
// Line segmentation

/// A weighted total-least-squares line x cos α + y sin α = ρ over a piece's valid beams.
#[derive(Debug, Clone, Copy)]
struct LineFit {
    rho: f64,
    alpha: f64,
    /// Σ (dᵢ/σᵢ)² (dᵢ orthogonal distances).
    rss: f64,
    /// max |dᵢ|/σᵢ.
    max_z: f64,
    /// Number of points.
    n: usize,
}

/// A run of beams [start, end]; its points are the valid beams inside.
#[derive(Debug, Clone, Copy)]
struct Piece {
    start: usize,
    end: usize,
    fit: Option<LineFit>,
}

struct LineScan<'p> {
    x: Vec<f64>,
    y: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
    sigma: Vec<f64>,
    valid: Vec<bool>,
    params: &'p LineParams,
}

impl LineScan<'_> {
    /// Weighted TLS fit (weights 1/σᵢ², i.e. generalised LS under σ ∝ r) of the valid beams in
    /// [start, end]; `None` below 2 points.
    fn fit(&self, start: usize, end: usize) -> Option<LineFit> {
        self.fit_skipping(start, end, (1, 0))
    }

    /// [`Self::fit`] without the beams in `skip` (inclusive; empty when skip.0 > skip.1).
    fn fit_skipping(&self, start: usize, end: usize, skip: (usize, usize)) -> Option<LineFit> {
        let member = |i: usize| self.valid[i] && !(skip.0..=skip.1).contains(&i);
        let (mut sw, mut sx, mut sy, mut n) = (0.0, 0.0, 0.0, 0usize);
        for i in start..=end {
            if member(i) {
                let w = 1.0 / (self.sigma[i] * self.sigma[i]);
                sw += w;
                sx += w * self.x[i];
                sy += w * self.y[i];
                n += 1;
            }
        }
        if n < 2 || sw.is_nan() || sw <= 0.0 {
            return None;
        }
        let (mx, my) = (sx / sw, sy / sw);
        let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
        for i in start..=end {
            if member(i) {
                let w = 1.0 / (self.sigma[i] * self.sigma[i]);
                let (dx, dy) = (self.x[i] - mx, self.y[i] - my);
                sxx += w * dx * dx;
                syy += w * dy * dy;
                sxy += w * dx * dy;
            }
        }
        // the normal angle minimising Σ w (x' cos α + y' sin α)²
        let mut alpha = 0.5 * (-2.0 * sxy).atan2(syy - sxx);
        let mut rho = mx * alpha.cos() + my * alpha.sin();
        if rho < 0.0 {
            rho = -rho;
            alpha += std::f64::consts::PI;
        }
        let (ca, sa) = (alpha.cos(), alpha.sin());
        let (mut rss, mut max_z) = (0.0, 0.0f64);
        for i in start..=end {
            if member(i) {
                let z = (self.x[i] * ca + self.y[i] * sa - rho) / self.sigma[i];
                rss += z * z;
                max_z = max_z.max(z.abs());
            }
        }
        Some(LineFit { rho, alpha, rss, max_z, n })
    }

    fn z_of(&self, i: usize, f: &LineFit) -> f64 {
        ((self.x[i] * f.alpha.cos() + self.y[i] * f.alpha.sin() - f.rho) / self.sigma[i]).abs()
    }

    /// Recursive split (iterative end-point fit with a noise-aware test): pushes the pieces of
    /// [start, end] (all beams valid on entry) in order; a split point that fits neither neighbour
    /// becomes invalid.
    fn split(&mut self, start: usize, end: usize, out: &mut Vec<Piece>) {
        if end - start < 2 {
            out.push(Piece { start, end, fit: self.fit(start, end) });
            return;
        }
        let fit = self.fit(start, end);
        if let Some(f) = fit
            && f.max_z <= self.params.split_sigmas
        {
            out.push(Piece { start, end, fit });
            return;
        }
        // split at the point farthest from the chord of the end points (IEPF)
        let (ax, ay, bx, by) = (self.x[start], self.y[start], self.x[end], self.y[end]);
        let len = (bx - ax).hypot(by - ay);
        let k = (start + 1..end)
            .max_by(|&i, &j| {
                let d = |m: usize| {
                    if len > 0.0 {
                        ((bx - ax) * (ay - self.y[m]) - (ax - self.x[m]) * (by - ay)).abs()
                    } else {
                        0.0
                    }
                };
                d(i).total_cmp(&d(j))
            })
            .unwrap_or(start + 1);
        let first_right = {
            self.split(start, k - 1, out);
            out.len()
        };
        self.split(k + 1, end, out);
        // re-attach k to the neighbouring piece it fits better, if it fits within split_sigmas
        let candidates = [(first_right - 1, true), (first_right, false)];
        let best = candidates
            .iter()
            .filter_map(|&(p, left)| {
                out[p].fit.filter(|f| f.n >= 2).map(|f| (p, left, self.z_of(k, &f)))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2));
        match best {
            Some((p, left, z)) if z <= self.params.split_sigmas => {
                if left {
                    out[p].end = k;
                } else {
                    out[p].start = k;
                }
                out[p].fit = self.fit(out[p].start, out[p].end);
            }
            _ => self.valid[k] = false,
        }
    }
}

/// The acceptable merge with the smallest χ² margin: of neighbouring pieces (p, p + 1), or with
/// `across_lone` of pieces (p, p + 2) around a lone piece that does not fit their joint line.
fn best_merge(ls: &LineScan, pieces: &[Piece], across_lone: bool) -> Option<(usize, usize, Piece)> {
    let params = ls.params;
    let step = if across_lone { 2 } else { 1 };
    let mut best: Option<(usize, usize, f64, Piece)> = None;
    for p in 0..pieces.len().saturating_sub(step) {
        let q = p + step;
        let (a, b) = (pieces[p], pieces[q]);
        if b.start - a.end - 1 > params.merge_gap_beams {
            continue;
        }
        let skip = if across_lone { (pieces[p + 1].start, pieces[p + 1].end) } else { (1, 0) };
        let Some(joint) = ls.fit_skipping(a.start, b.end, skip) else { continue };
        if joint.max_z > params.split_sigmas {
            continue;
        }
        if across_lone
            && (skip.0..=skip.1).any(|i| ls.valid[i] && ls.z_of(i, &joint) <= params.split_sigmas)
        {
            continue; // the middle piece fits: it belongs to the line, merge it as a neighbour
        }
        let part = |f: Option<LineFit>| f.map_or((0.0, 0), |f| (f.rss, f.n.saturating_sub(2)));
        let ((rss_a, dof_a), (rss_b, dof_b)) = (part(a.fit), part(b.fit));
        let dof = (joint.n - 2).saturating_sub(dof_a + dof_b);
        let delta = joint.rss - rss_a - rss_b;
        let margin = delta - chi2_quantile(params.merge_alpha, dof);
        if margin <= 0.0 && best.as_ref().is_none_or(|(_, _, m, _)| margin < *m) {
            best = Some((p, q, margin, Piece { start: a.start, end: b.end, fit: Some(joint) }));
        }
    }
    best.map(|(p, q, _, piece)| (p, q, piece))
}

/// Upper (1 − α) quantile of χ²(ν): exact for ν = 1 (z²) and ν = 2 (−2 ln α), Wilson–Hilferty
/// above.
fn chi2_quantile(alpha: f64, dof: usize) -> f64 {
    match dof {
        0 => 0.0,
        1 => normal_quantile(1.0 - alpha / 2.0).powi(2),
        2 => -2.0 * alpha.ln(),
        _ => {
            let nu = dof as f64;
            let z = normal_quantile(1.0 - alpha);
            nu * (1.0 - 2.0 / (9.0 * nu) + z * (2.0 / (9.0 * nu)).sqrt()).powi(3)
        }
    }
}

/// Standard normal quantile (Acklam's rational approximation, relative error < 1.2e-9).
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] =
        [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    const P_LOW: f64 = 0.02425;
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < P_LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - P_LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Range along the ray (cos φ, sin φ) to the chord through a and b, if it is ahead.
fn chord_range(ax: f64, ay: f64, bx: f64, by: f64, cos_phi: f64, sin_phi: f64) -> Option<f64> {
    let t = (ax * by - ay * bx) / (cos_phi * (by - ay) - sin_phi * (bx - ax));
    (t.is_finite() && t > 0.0).then_some(t)
}

/// k̂ of σ(r) = k·r: robust MAD of each interior point's range deviation from the chord of its two
/// neighbours (consecutive valid beams), δᵢ/rᵢ; Var δᵢ = 1.5 σ² for independent equal-σ noise on
/// a straight wall; corners and jumps are a minority the median ignores. 0 below 5 samples.
fn estimate_noise_k(r: &[f64], valid: &[bool], cos: &[f64], sin: &[f64]) -> f64 {
    const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602; // 1 / Φ⁻¹(0.75)
    const MIN_SAMPLES: usize = 5;
    let mut rel: Vec<f64> = (1..r.len().saturating_sub(1))
        .filter(|&i| valid[i - 1] && valid[i] && valid[i + 1])
        .filter_map(|i| {
            let (ax, ay) = (r[i - 1] * cos[i - 1], r[i - 1] * sin[i - 1]);
            let (bx, by) = (r[i + 1] * cos[i + 1], r[i + 1] * sin[i + 1]);
            chord_range(ax, ay, bx, by, cos[i], sin[i]).map(|c| ((r[i] - c) / r[i]).abs())
        })
        .collect();
    if rel.len() < MIN_SAMPLES {
        return 0.0;
    }
    let mid = rel.len() / 2;
    let (_, median, _) = rel.select_nth_unstable_by(mid, f64::total_cmp);
    *median * MAD_TO_SIGMA / 1.5f64.sqrt()
}

/// Line segmentation (see [`LineParams`]): runs → split → merge → drop short → project ranges onto
/// the lines.
pub fn lines(
    ranges: &[Option<f64>],
    angle_min_rad: f64,
    angle_increment_rad: f64,
    max_range_m: f64,
    params: &LineParams,
) -> PolarScan {
    let n = ranges.len();
    let r: Vec<f64> =
        ranges.iter().map(|r| r.filter(|&r| usable_range(r, max_range_m)).unwrap_or(0.0)).collect();
    let valid: Vec<bool> =
        ranges.iter().map(|r| r.is_some_and(|r| usable_range(r, max_range_m))).collect();
    let phi: Vec<f64> = (0..n).map(|i| angle_min_rad + i as f64 * angle_increment_rad).collect();
    let cos: Vec<f64> = phi.iter().map(|p| p.cos()).collect();
    let sin: Vec<f64> = phi.iter().map(|p| p.sin()).collect();
    let k = params.noise_k.unwrap_or_else(|| estimate_noise_k(&r, &valid, &cos, &sin));
    let sigma: Vec<f64> = r.iter().map(|&r| (k * r).max(params.sigma_floor_m)).collect();
    let mut ls = LineScan {
        x: r.iter().zip(&cos).map(|(r, c)| r * c).collect(),
        y: r.iter().zip(&sin).map(|(r, s)| r * s).collect(),
        cos,
        sin,
        sigma,
        valid,
        params,
    };

    // 1. runs of consecutive valid beams, broken at range jumps; 2. split each run
    let mut pieces: Vec<Piece> = Vec::new();
    let mut i = 0;
    while i < n {
        if !ls.valid[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i + 1 < n && ls.valid[i + 1] && {
            let jump = params.jump_m.max(
                params.jump_sigmas * std::f64::consts::SQRT_2 * ls.sigma[i].max(ls.sigma[i + 1]),
            );
            (r[i + 1] - r[i]).abs() <= jump
        } {
            i += 1;
        }
        ls.split(start, i, &mut pieces);
        i += 1;
    }

    // 3. merge adjacent collinear pieces, most compatible pair first. Neighbours first; only when
    //    no neighbours merge, pieces at most merge_gap_beams beams apart whose gap holds one lone
    //    piece that does NOT fit the joint line (e.g. a single-beam outlier split off by the jump
    //    test) — the lone piece is then dropped.
    while let Some((p, q, merged)) =
        best_merge(&ls, &pieces, false).or_else(|| best_merge(&ls, &pieces, true))
    {
        if q == p + 2 {
            let lone = pieces[p + 1];
            ls.valid[lone.start..=lone.end].fill(false);
        }
        pieces[p] = merged;
        pieces.drain(p + 1..=q);
    }

    // 4. drop short pieces; 5. label and project each beam onto its line
    let mut scan = PolarScan {
        angle_min_rad,
        angle_increment_rad,
        ranges: vec![0.0; n],
        valid: vec![false; n],
        segment: vec![0; n],
    };
    let mut label = 0u32;
    for piece in &pieces {
        let Some(fit) = piece.fit.filter(|f| f.n >= params.min_points) else { continue };
        label += 1;
        for i in piece.start..=piece.end {
            if !ls.valid[i] {
                continue;
            }
            // the beam ray meets the line x cos α + y sin α = ρ at r = ρ / cos(φ − α)
            let cos_incidence = ls.cos[i] * fit.alpha.cos() + ls.sin[i] * fit.alpha.sin();
            let on_line = fit.rho / cos_incidence;
            if on_line.is_finite() && on_line > 0.0 {
                scan.ranges[i] = on_line;
                scan.valid[i] = true;
                scan.segment[i] = label;
            }
        }
    }
    scan
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scanmatch::scan::testing::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn describe_names_the_method_and_line_thresholds() {
        let p = SegmentationParams {
            method: Segmentation::PsmHeuristics,
            lines: LineParams {
                split_sigmas: 3.5,
                merge_alpha: 0.05,
                min_points: 6,
                ..LineParams::default()
            },
            ..SegmentationParams::default()
        };
        let s = p.describe();
        assert!(
            s.starts_with("Preprocessing (PSM's heuristics):")
                && s.contains("more than 3.5 σ off")
                && s.contains("α = 0.05")
                && s.contains("under 6 points"),
            "{s}"
        );
    }

    fn room_raw() -> (Beams, Vec<Option<f64>>) {
        let beams = Beams::lms200();
        let raw = cast_scan(&rect_room_with_column(), ROOM_REFERENCE_POSE, &beams, MAX_RANGE_M);
        (beams, raw)
    }

    fn lines_default(beams: &Beams, raw: &[Option<f64>]) -> PolarScan {
        lines(
            raw,
            beams.angle_min_rad,
            beams.angle_increment_rad,
            MAX_RANGE_M,
            &LineParams::default(),
        )
    }

    #[test]
    fn lines_reproduce_a_noise_free_room() {
        let (beams, raw) = room_raw();
        let s = lines_default(&beams, &raw);
        // left wall, far wall above the column, column face, far wall below, right wall
        assert_eq!(s.segment_count(), 5, "{:?}", s.segment);
        for (i, r) in raw.iter().enumerate() {
            assert!(s.valid[i], "beam {i}");
            assert!((s.ranges[i] - r.unwrap()).abs() < 1e-9, "beam {i}: {} vs {r:?}", s.ranges[i]);
        }
        // labels are contiguous blocks in scan order
        assert!(s.segment.windows(2).all(|w| w[1] == w[0] || w[1] == w[0] + 1));
    }

    #[test]
    fn lines_count_walls_in_the_polygon_room() {
        let beams = Beams::lms200();
        let walls = polygon_room();
        let raw = cast_scan(&walls, POLYGON_REFERENCE_POSE, &beams, MAX_RANGE_M);
        let s = lines_default(&beams, &raw);
        // every segment's beams lie on one wall, and no wall seen by ≥ 4 beams is split
        let pose = POLYGON_REFERENCE_POSE;
        let wall_of = |i: usize| {
            let p = pose.transform_point(crate::geom::Point2::new(
                s.ranges[i] * s.bearing(i).cos(),
                s.ranges[i] * s.bearing(i).sin(),
            ));
            walls.iter().position(|w| w.distance_to_point(p) < 1e-9)
        };
        let mut seen_walls = std::collections::BTreeMap::new();
        for (i, r) in raw.iter().enumerate() {
            if let Some(r) = r {
                assert!((s.ranges[i] - r).abs() < 1e-9 || !s.valid[i], "beam {i}");
            }
            if s.valid[i] {
                *seen_walls.entry(wall_of(i).expect("on a wall")).or_insert(0) += 1;
            }
        }
        let visible_runs = seen_walls.values().filter(|&&c| c >= 4).count();
        assert_eq!(
            s.segment_count(),
            visible_runs,
            "segments {:?} walls {seen_walls:?}",
            s.segment
        );
    }

    #[test]
    fn lines_filter_proportional_noise() {
        let (beams, raw) = room_raw();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut raw_sq, mut filt_sq, mut n) = (0.0, 0.0, 0);
        for _ in 0..10 {
            let noisy = add_range_noise(&raw, 0.020, &mut rng);
            let s = lines_default(&beams, &noisy);
            for i in 0..s.len() {
                if s.valid[i] {
                    let truth = raw[i].unwrap();
                    raw_sq += (noisy[i].unwrap() - truth).powi(2);
                    filt_sq += (s.ranges[i] - truth).powi(2);
                    n += 1;
                }
            }
        }
        let (raw_rms, filt_rms) = ((raw_sq / n as f64).sqrt(), (filt_sq / n as f64).sqrt());
        assert!(n > 10 * 150, "most beams stay valid: {n}");
        assert!(filt_rms < 0.4 * raw_rms, "filtered {filt_rms} vs raw {raw_rms}");
    }

    #[test]
    fn noise_k_is_estimated() {
        let (beams, raw) = room_raw();
        let cos: Vec<f64> = (0..181).map(|i| beams.bearing(i).cos()).collect();
        let sin: Vec<f64> = (0..181).map(|i| beams.bearing(i).sin()).collect();
        let valid = vec![true; 181];
        let r: Vec<f64> = raw.iter().map(|r| r.unwrap()).collect();
        assert!(estimate_noise_k(&r, &valid, &cos, &sin) < 1e-9);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut ks = vec![];
        for _ in 0..20 {
            let noisy: Vec<f64> =
                add_range_noise(&raw, 0.01, &mut rng).iter().map(|r| r.unwrap()).collect();
            ks.push(estimate_noise_k(&noisy, &valid, &cos, &sin));
        }
        let mean = ks.iter().sum::<f64>() / ks.len() as f64;
        assert!((mean - 0.01).abs() < 0.0015, "k̂ = {mean}");
    }

    #[test]
    fn single_beam_outliers_become_invalid() {
        let (beams, mut raw) = room_raw();
        // a chair leg on the left wall (1 m short), a 12 cm spike on the far wall, a far reading
        for (i, dr) in [(150usize, -1.0), (100, 0.12), (30, 3.0)] {
            raw[i] = raw[i].map(|r| r + dr);
        }
        let clean = room_raw().1;
        let s = lines_default(&beams, &raw);
        for i in [150, 100, 30] {
            assert!(!s.valid[i] && s.segment[i] == 0, "beam {i}");
        }
        for i in (0..181).filter(|i| ![150, 100, 30].contains(i)) {
            assert!(s.valid[i] && (s.ranges[i] - clean[i].unwrap()).abs() < 1e-9, "beam {i}");
        }
        assert_eq!(s.segment_count(), 5);
    }

    #[test]
    fn psm_heuristics_follow_diosi() {
        // median: a 1-beam spike disappears; 2-beam spike too (window 5 needs 3 to survive)
        let mut raw: Vec<Option<f64>> = vec![Some(3.0); 20];
        raw[5] = Some(1.0);
        raw[10] = Some(1.0);
        raw[11] = Some(1.0);
        raw[15] = None; // no return
        let s = psm_heuristics(&raw, -0.2, 0.02, 10.0, &PsmHeuristicsParams::default());
        assert!(s.ranges.iter().zip(&s.valid).all(|(&r, &v)| !v || r == 3.0));
        assert!(s.valid.iter().all(|&v| v), "one None among 3.0s is filtered by the median");
        assert_eq!(s.segment_count(), 1);
        // far points: beyond max range → bad
        let raw: Vec<Option<f64>> = (0..10).map(|i| Some(if i < 5 { 2.0 } else { 12.0 })).collect();
        let s = psm_heuristics(&raw, 0.0, 0.01, 10.0, &PsmHeuristicsParams::default());
        assert_eq!(s.valid, [true, true, true, true, true, false, false, false, false, false]);
        assert_eq!(&s.segment[..5], &[1; 5]);
        // oblique wall: steps of 0.3 m are continued by the extrapolation rule
        let r: Vec<f64> = (0..8).map(|i| 2.0 + 0.3 * i as f64).collect();
        let seg = psm_segment(&r, &[false; 8], 0.2);
        // first pair breaks (|Δr| = 0.3): point 0 isolated; then 1,2 … the lone-point rule joins 0,1,2
        assert_eq!(seg, [1, 1, 1, 1, 1, 1, 1, 1]);
        // jumps split; lone point between two jumps is segment 0
        let r = [1.0, 1.0, 1.0, 5.0, 9.0, 9.0, 9.0];
        assert_eq!(psm_segment(&r, &[false; 7], 0.2), [1, 1, 1, 0, 2, 2, 2]);
        // a bad point breaks a segment
        // (PSM gives the bad point the next segment's number; `psm_heuristics` clears it)
        let r = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let bad = [false, false, false, true, false, false];
        assert_eq!(psm_segment(&r, &bad, 0.2), [1, 1, 1, 2, 2, 2]);
        let raw: Vec<Option<f64>> = bad.iter().map(|&b| Some(if b { 20.0 } else { 1.0 })).collect();
        let mut p = PsmHeuristicsParams { median_window: 1, ..Default::default() };
        assert_eq!(psm_heuristics(&raw, 0.0, 0.01, 10.0, &p).segment, [1, 1, 1, 0, 2, 2]);
        p.median_window = 5;
        assert_eq!(psm_heuristics(&raw, 0.0, 0.01, 10.0, &p).segment, [1; 6]);
    }

    /// v0.3's median filter writes each result back before the next window is read: a running
    /// median. On alternating ranges the filtered left half of each window keeps the first value.
    #[test]
    fn psm_median_filter_runs_in_place_as_v03() {
        let raw: Vec<Option<f64>> =
            [5.0, 1.0, 5.0, 1.0, 5.0, 1.0, 5.0].iter().map(|&r| Some(r)).collect();
        let s = psm_heuristics(&raw, 0.0, 0.01, 10.0, &PsmHeuristicsParams::default());
        assert_eq!(s.ranges, [5.0; 7]);
        // (a median of the raw ranges would alternate from beam 3 on: 5, 5, 5, 1, 5, 1, 5)
    }

    #[test]
    fn psm_heuristics_on_the_room_keep_walls() {
        let (beams, raw) = room_raw();
        let s = psm_heuristics(
            &raw,
            beams.angle_min_rad,
            beams.angle_increment_rad,
            MAX_RANGE_M,
            &PsmHeuristicsParams::default(),
        );
        assert!(s.valid.iter().all(|&v| v));
        // the column (9 beams) survives the median; jumps at its edges make ≥ 3 segments
        assert!(s.segment_count() >= 3, "{:?}", s.segment);
    }

    #[test]
    fn none_is_contiguous_runs() {
        let raw = [Some(1.0), Some(5.0), None, Some(2.0)];
        let p = SegmentationParams { method: Segmentation::None, ..Default::default() };
        let s = prepare(&raw, 0.0, 0.1, 10.0, &p);
        assert_eq!(s.segment, [1, 1, 0, 0]);
        assert_eq!(s.valid, [true, true, false, true]);
    }

    #[test]
    fn bad_input_never_panics() {
        let odd = [Some(f64::NAN), Some(-1.0), None, Some(f64::INFINITY), Some(0.0), Some(3.0)];
        for method in [Segmentation::Lines, Segmentation::PsmHeuristics, Segmentation::None] {
            let p = SegmentationParams { method, ..Default::default() };
            for raw in [&odd[..], &[], &[Some(1.0)], &[None, None]] {
                let s = prepare(raw, -1.0, 0.01, 10.0, &p);
                assert_eq!(s.len(), raw.len());
                assert!(s.is_consistent(), "{method:?} {raw:?}");
            }
        }
    }

    #[test]
    fn params_validate_and_parse() {
        assert!(SegmentationParams::default().validate().is_empty());
        let bad = SegmentationParams {
            psm_heuristics: PsmHeuristicsParams { median_window: 4, ..Default::default() },
            lines: LineParams { merge_alpha: 0.0, min_points: 1, ..Default::default() },
            ..Default::default()
        };
        let keys: Vec<String> = bad.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["psm_heuristics.median_window", "lines.merge_alpha", "lines.min_points"]);
        let p: SegmentationParams =
            toml::from_str("method = \"psm_heuristics\"\n[lines]\nnoise_k = 0.02").unwrap();
        assert_eq!(p.method, Segmentation::PsmHeuristics);
        assert_eq!(p.lines.noise_k, Some(0.02));
        assert!(toml::from_str::<SegmentationParams>("[lines]\nsplit_sigma = 3").is_err());
        assert!((chi2_quantile(0.01, 2) - 9.2103).abs() < 1e-3);
        assert!((chi2_quantile(0.01, 1) - 6.6349).abs() < 1e-3);
        assert!((chi2_quantile(0.01, 5) - 15.086).abs() < 0.1);
    }
}
