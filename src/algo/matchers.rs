//! The built-in scan matchers ([EP]): PSM on the study's segmentation or on its own heuristics,
//! E-PSM, the brute-force reference, the simultaneous search with each of NLopt's optimisers and
//! PL-ICP. All run through `scanmatch::track` (trigger, initial guess, chaining); they differ in
//! the matcher of one pair. The laser pose graph (`slam::pose_graph`) runs any of them as its
//! front end.

use super::{Algorithm, Choice, Listing, Output, Role, RunInput, RunSize, Topic, Work};
use crate::params::Params;
use crate::scanmatch::brute::BruteForceMode;
use crate::scanmatch::search::Optimizer;
use crate::scanmatch::track::{self, Matcher};
use crate::trace::SlamError;
use crate::world::{Sensors, WorldKind};
use std::borrow::Cow;
use std::sync::Arc;

/// Code version of TNEWTON runs: the scan matchers' plus NLopt's PNET with its work array and
/// `mx` zeroed (`build/nlopt_patch.rs`).
pub const TNEWTON_CODE_VERSION: &str = "scanmatch-3+pnet-zeroed-1";

/// Polar Scan Matching (Diosi & Kleeman) on scans prepared by the study's
/// `[scan_matching.segmentation]` ([EP]'s "Diosi": PSM on segmented scans), or with its own
/// preprocessing heuristics whatever the study's segmentation ([EP] Table 4's "Diosi Original").
pub struct Psm {
    pub own_heuristics: bool,
}

/// E-PSM's alternating orientation/position search ([EP] §5.3.1).
pub struct Epsm;

/// The brute-force reference: a translation grid with E-PSM's orientation search ([EP] §6.1).
pub struct BruteForce;

/// PL-ICP, point-to-line ICP (Censi, ICRA 2008), on the raw points.
pub struct PlIcp;

/// Simultaneous (x, y, θ) search with one of NLopt's optimisers ([EP] §5.3.2); listed by the
/// optimiser's name (`crs2`, `direct_l`, …).
pub struct PoseSearch(pub Optimizer);

/// The sentences every scan matcher shares, and `own`: its own section's.
fn choices(p: &Params, own: Choice) -> Vec<Choice> {
    let sm = &p.scan_matching;
    vec![
        Choice { topic: Topic::ScanMatching, text: sm.describe() },
        Choice { topic: Topic::ScanObjective, text: sm.objective.describe() },
        Choice { topic: Topic::ScanSegmentation, text: sm.segmentation.describe() },
        own,
        Choice { topic: Topic::MatchErrors, text: track::describe_errors().into() },
    ]
}

/// A matcher's work: matches × beams × evaluations of the objective per match, the matches
/// bounded by the trigger distance, the scans and `max_matches`.
fn match_work(p: &Params, size: &RunSize, evaluations: f64) -> Work {
    let sm = &p.scan_matching;
    let trigger_m = if sm.trigger_distance_m > 0.0 { sm.trigger_distance_m } else { 0.5 };
    let mut matches = (size.path_m / trigger_m).min(size.scans);
    if sm.max_matches > 0 {
        matches = matches.min(f64::from(sm.max_matches));
    }
    Work {
        extraction: matches * size.beams,
        matching: matches * size.beams * evaluations,
        ..Work::default()
    }
}

/// Tracks the world's scans with `matcher`: the trajectory and one record per match.
fn track(input: RunInput<'_>, matcher: Matcher<'_>) -> Result<Output, SlamError> {
    let tracked =
        track::track(input.world, matcher, &input.params.scan_matching, input.seed, input.clock)?;
    Ok(Output { trace: tracked.trace, steps: Some(tracked.steps) })
}

fn sections(own: &str) -> Vec<String> {
    vec!["scan_matching".to_string(), own.to_string()]
}

impl Algorithm for Psm {
    fn name(&self) -> &str {
        if self.own_heuristics { "psm_original" } else { "psm" }
    }
    fn title(&self) -> &str {
        if self.own_heuristics { "PSM (own heuristics)" } else { "PSM" }
    }
    fn summary(&self) -> Cow<'_, str> {
        if self.own_heuristics {
            "PSM with its own preprocessing heuristics ([EP] Table 4's \"Diosi Original\")".into()
        } else {
            "Polar Scan Matching (Diosi & Kleeman) on the study's segmentation ([EP]'s \"Diosi\")"
                .into()
        }
    }
    fn code_version(&self) -> Cow<'_, str> {
        track::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::ScanMatcher
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LASER
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        sections("psm")
    }
    fn describe(&self, p: &Params, _: &Listing<'_>) -> Vec<Choice> {
        choices(p, Choice { topic: Topic::Psm, text: p.psm.describe() })
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        // evaluations of the objective per match: the means measured in the [EP] studies
        // (matches.parquet), bounded by the budget where one applies
        match_work(p, size, 12.0)
    }
    fn matcher<'p>(&self, p: &'p Params) -> Option<Matcher<'p>> {
        Some(Matcher::Psm { params: &p.psm, own_heuristics: self.own_heuristics })
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let matcher = self.matcher(input.params).expect("PSM is a matcher");
        track(input, matcher)
    }
}

impl Algorithm for Epsm {
    fn name(&self) -> &str {
        "epsm"
    }
    fn title(&self) -> &str {
        "E-PSM"
    }
    fn summary(&self) -> Cow<'_, str> {
        "E-PSM's alternating orientation/position search ([EP] §5.3.1), optionally with BOBYQA and the f-check".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        track::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::ScanMatcher
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LASER
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        sections("epsm")
    }
    fn describe(&self, p: &Params, _: &Listing<'_>) -> Vec<Choice> {
        choices(p, Choice { topic: Topic::Epsm, text: p.epsm.describe() })
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        match_work(p, size, 670.0)
    }
    fn matcher<'p>(&self, p: &'p Params) -> Option<Matcher<'p>> {
        Some(Matcher::Epsm(&p.epsm))
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        track(input, Matcher::Epsm(&p.epsm))
    }
}

impl Algorithm for BruteForce {
    fn name(&self) -> &str {
        "brute_force"
    }
    fn title(&self) -> &str {
        "Brute force"
    }
    fn summary(&self) -> Cow<'_, str> {
        "the brute-force reference: E-PSM's orientation search at every cell of a translation grid ([EP] §6.1)".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        track::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::ScanMatcher
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LASER
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        sections("brute_force")
    }
    fn describe(&self, p: &Params, _: &Listing<'_>) -> Vec<Choice> {
        choices(p, Choice { topic: Topic::BruteForce, text: p.brute_force.describe() })
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        let b = &p.brute_force;
        let side = 2.0 * (b.half_window_m / b.step_m.max(1e-6)).round() + 1.0;
        // E-PSM's orientation search at a cell: ≈ 121 evaluations
        let evaluations = match b.mode {
            BruteForceMode::Nested => side * side * 121.0,
            BruteForceMode::Descent => side * side + f64::from(b.max_moves).min(20.0) * 8.0 * 121.0,
        };
        match_work(p, size, evaluations)
    }
    fn matcher<'p>(&self, p: &'p Params) -> Option<Matcher<'p>> {
        Some(Matcher::BruteForce(&p.brute_force))
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        track(input, Matcher::BruteForce(&p.brute_force))
    }
}

impl Algorithm for PoseSearch {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn title(&self) -> &str {
        self.0.title()
    }
    fn summary(&self) -> Cow<'_, str> {
        let paper = match self.0 {
            Optimizer::Lbfgs => " (the paper's \"BFGS\")",
            Optimizer::Tnewton => " (the paper's \"NEWTON\")",
            _ => "",
        };
        format!(
            "simultaneous (x, y, θ) search with NLopt's {}{paper} ([EP] §5.3.2)",
            self.0.title()
        )
        .into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        // TNEWTON's results depended on heap garbage before NLopt's PNET was patched to zero its
        // work array (build/nlopt_patch.rs): its cache entries carry their own version
        match self.0 {
            Optimizer::Tnewton => TNEWTON_CODE_VERSION.into(),
            _ => track::CODE_VERSION.into(),
        }
    }
    fn role(&self) -> Role {
        Role::ScanMatcher
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LASER
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        sections("pose_search")
    }
    fn describe(&self, p: &Params, _: &Listing<'_>) -> Vec<Choice> {
        choices(p, Choice { topic: Topic::PoseSearch, text: p.pose_search.describe() })
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        use Optimizer as O;
        let maxeval = f64::from(p.pose_search.maxeval.max(1));
        let evaluations = match self.0 {
            O::DirectL | O::Isres => maxeval,
            O::MlslLds => 4.0 * maxeval,
            O::Crs2 => maxeval.min(960.0),
            O::Bobyqa => 32.0,
            O::Cobyla => 46.0,
            O::Slsqp => 75.0,
            O::Lbfgs | O::Var2 => 90.0,
            O::Tnewton => 127.0,
            O::Sbplx => 154.0,
        };
        match_work(p, size, evaluations)
    }
    fn matcher<'p>(&self, p: &'p Params) -> Option<Matcher<'p>> {
        Some(Matcher::PoseSearch { optimizer: self.0, params: &p.pose_search })
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        track(input, Matcher::PoseSearch { optimizer: self.0, params: &p.pose_search })
    }
}

impl Algorithm for PlIcp {
    fn name(&self) -> &str {
        "pl_icp"
    }
    fn title(&self) -> &str {
        "PL-ICP"
    }
    fn summary(&self) -> Cow<'_, str> {
        "PL-ICP, point-to-line ICP (Censi, ICRA 2008) on the raw points, with CSM sm2's defaults"
            .into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        format!("{}+{}", track::CODE_VERSION, crate::scanmatch::plicp::CODE_VERSION).into()
    }
    fn role(&self) -> Role {
        Role::ScanMatcher
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LASER
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        sections("pl_icp")
    }
    fn describe(&self, p: &Params, _: &Listing<'_>) -> Vec<Choice> {
        choices(p, Choice { topic: Topic::PlIcp, text: p.pl_icp.describe() })
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        // the common objective scores the estimate and the guess (3 evaluations); the ICP
        // iterations cost about as much as a few more
        match_work(p, size, 8.0)
    }
    fn matcher<'p>(&self, p: &'p Params) -> Option<Matcher<'p>> {
        Some(Matcher::PlIcp(&p.pl_icp))
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        track(input, Matcher::PlIcp(&p.pl_icp))
    }
}

/// The laser pose graph (`slam::pose_graph`): scan-matching edges and loop closures, optimised;
/// its front end is any built-in scan matcher, named by `[pose_graph] front_end`.
pub struct PoseGraph;

impl PoseGraph {
    /// The front end `params` name (validated against `pose_graph::front_ends()` when the spec
    /// was read, and those against the registry by a test).
    fn front_end(params: &Params) -> Arc<dyn Algorithm> {
        let name = &params.pose_graph.front_end;
        super::builtins()
            .into_iter()
            .find(|a| a.name() == name && a.is_scan_matcher())
            .unwrap_or_else(|| panic!("pose_graph.front_end `{name}` was validated"))
    }
}

impl Algorithm for PoseGraph {
    fn name(&self) -> &str {
        "pose_graph"
    }
    fn title(&self) -> &str {
        "Pose graph"
    }
    fn summary(&self) -> Cow<'_, str> {
        "laser pose-graph SLAM: a scan matcher's consecutive matches and loop closures (revisited scans matched and kept by an overlap test), optimised by Levenberg–Marquardt under Cauchy's kernel; any built-in scan matcher is the front end".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        // the front end is a parameter: every matcher's version is in it
        format!(
            "{}+{}+{}+{}",
            crate::slam::pose_graph::CODE_VERSION,
            crate::slam::graph::CODE_VERSION,
            crate::scanmatch::plicp::CODE_VERSION,
            TNEWTON_CODE_VERSION,
        )
        .into()
    }
    fn role(&self) -> Role {
        Role::ScanMatcher
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LASER
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        // the front end's section is a parameter: all of them
        [
            "scan_matching",
            "psm",
            "epsm",
            "pose_search",
            "brute_force",
            "pl_icp",
            "motion_model",
            "graph",
            "pose_graph",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    }
    fn describe(&self, p: &Params, study: &Listing<'_>) -> Vec<Choice> {
        let mut out = Self::front_end(p).describe(p, study);
        out.push(Choice { topic: Topic::PoseGraph, text: p.pose_graph.describe() });
        out
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        // every scan is matched once more against each loop-closure candidate, at most
        let w = Self::front_end(p).work(p, size);
        let k = 1.0 + f64::from(p.pose_graph.loop_candidates);
        Work { extraction: w.extraction, matching: w.matching * k, ..w }
    }
    fn matcher<'p>(&self, p: &'p Params) -> Option<Matcher<'p>> {
        Self::front_end(p).matcher(p)
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        let matcher = self.matcher(p).expect("a built-in scan matcher has a matcher");
        let run = crate::slam::pose_graph::pose_graph(
            input.world,
            matcher,
            &p.scan_matching,
            &p.pose_graph,
            &p.graph,
            &p.motion_model,
            input.seed,
            input.clock,
        )?;
        Ok(Output { trace: run.trace, steps: Some(run.steps) })
    }
}
