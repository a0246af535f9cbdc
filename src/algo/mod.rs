//! The algorithms a study can list: one trait, [`Algorithm`], and one [`Catalogue`] of them — the
//! built-in filters ([`filters`]) and scan matchers ([`matchers`]), and the external programs
//! declared in `data/algorithms/` ([`external`]). Everything the pipeline asks of an algorithm
//! is asked here: its name and title, the code version in its runs' hashes, the sensors and
//! `[base]` sections it reads, the sentences the report states about it, the work a run costs
//! (shards, progress), and the run itself.
//!
//! A floor between `plan/` (which resolves a spec's names against the catalogue) and the cores
//! (`slam/`, `scanmatch/`), which do not know it. Pure: an external program is started by a
//! launcher the caller passes in ([`RunInput::launch`], `run/external.rs`).
//!
//! Adding a built-in algorithm: its core, one `impl Algorithm` (the compiler asks for every
//! method: none has a default but the derived ones), one line in [`builtins`], and its parameter
//! section in `Params` — docs/src/development/architecture.md walks through it.

pub mod external;
pub mod filters;
pub mod matchers;

use crate::features::{FeatureParams, ScanFeatures};
use crate::params::Params;
use crate::scanmatch::track::Matcher;
use crate::trace::{SlamError, Trace};
use crate::world::{Sensors, World, WorldKind};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::sync::Arc;

/// An algorithm's name as specs, run ids and Parquet write it (`fastslam1`, `ekf_slam_py`). A
/// spec keeps the names as written; the plan resolves them against the [`Catalogue`].
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(transparent)]
pub struct AlgorithmId(pub String);

impl AlgorithmId {
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for AlgorithmId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// What an algorithm estimates from, which decides how its runs are driven and measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A trajectory (and maybe a map) from odometry and a sensor: dead reckoning, the filters.
    Estimator,
    /// Laser odometry by matching consecutive scans ([EP]): its runs stop at the last match, are
    /// scored per match, and get match diagnostics.
    ScanMatcher,
}

/// One modelling-choice sentence of a report, with the topic that orders it: the report states
/// each distinct (topic, sentence) once, in topic order, whichever algorithms gave it.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Choice {
    pub topic: Topic,
    pub text: String,
}

/// Where a [`Choice`] stands in a report's list, after the world's sentences (clock, odometry,
/// laser); the landmark sensor's sentence stands just before [`Topic::MotionModel`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Topic {
    /// Line and corner extraction from laser scans ([FT] Ch. 4).
    Features,
    /// FastSLAM on laser worlds ([FT] Table 6.3).
    FastslamOnLasers,
    /// The motion model a filter is told.
    MotionModel,
    /// FastSLAM on point-landmark worlds ([PF]) and FastSLAM 2.0.
    FastslamOnPoints,
    Ekf,
    /// Graph-based SLAM (smoothing).
    Graph,
    /// What every scan matcher shares: trigger, initial guess, chaining.
    ScanMatching,
    ScanObjective,
    ScanSegmentation,
    Psm,
    Epsm,
    BruteForce,
    PoseSearch,
    PlIcp,
    /// The laser pose graph built on a front end's matches.
    PoseGraph,
    /// How scan-matching errors are measured.
    MatchErrors,
    /// An algorithm's own sentence (an external program's description).
    Own,
}

/// What `describe` knows of the study: its world kinds and every algorithm it lists.
#[derive(Debug, Clone, Copy)]
pub struct Listing<'a> {
    pub kinds: &'a [WorldKind],
    pub names: &'a [&'a str],
}

impl Listing<'_> {
    pub fn lists(&self, name: &str) -> bool {
        self.names.contains(&name)
    }

    pub fn has(&self, kind: WorldKind) -> bool {
        self.kinds.contains(&kind)
    }
}

/// The sizes of a run that its work is counted from (`plan::cost`), taken from the spec alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSize {
    pub kind: WorldKind,
    /// Odometry steps.
    pub steps: f64,
    /// Length of the route [m].
    pub path_m: f64,
    /// Laser scans and beams per scan (0 when the algorithm reads no laser).
    pub scans: f64,
    pub beams: f64,
    /// Steps with an observation update: scans on a laser world, landmark readings' steps on a
    /// point world.
    pub updates: f64,
    /// Landmarks of the map (lines, corners and points).
    pub landmarks: f64,
}

/// Sizes of a run's work, in counts (not seconds): `plan::cost` weighs them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Work {
    /// Odometry steps (the other terms derive from them; no weight of its own).
    pub steps: f64,
    /// Beams of the scans whose features are extracted.
    pub extraction: f64,
    /// Filter updates on laser features: scans × particles × landmarks (FastSLAM), scans ×
    /// landmarks² (EKF).
    pub filter: f64,
    /// The same on point-landmark readings (readings per step × particles × landmarks).
    pub filter_points: f64,
    /// Matches × beams × (iterations or evaluations) of a scan matcher.
    pub matching: f64,
    /// Steps of a real log (read, not simulated).
    pub log_steps: f64,
    /// Seconds of an external program's run, as its descriptor expects.
    pub external_s: f64,
}

/// A program to start: its command (with `{input}` and `{output}` still in it), the files of its
/// input folder, and the files to read back from its output folder.
#[derive(Debug, Clone, PartialEq)]
pub struct Launch<'a> {
    pub command: &'a [String],
    pub inputs: Vec<(&'static str, String)>,
    pub outputs: &'a [&'static str],
    pub timeout_s: f64,
}

/// The output files a launched program wrote (`None`: it wrote no such file).
pub type Launched = Vec<(&'static str, Option<String>)>;

/// Everything one run of an algorithm may read.
pub struct RunInput<'a> {
    pub world: &'a World,
    pub kind: WorldKind,
    pub params: &'a Params,
    pub run_id: &'a str,
    /// The run's filter seed: every random draw of the algorithm comes from it.
    pub seed: u64,
    /// The features of the world's scans with these parameters, extracted once per world.
    pub features: &'a dyn Fn(&FeatureParams) -> Result<Arc<Vec<ScanFeatures>>, SlamError>,
    /// Seconds since the run started (scan matchers time each match).
    pub clock: &'a mut dyn FnMut() -> f64,
    /// Starts a program and returns what it wrote, or why it failed.
    pub launch: &'a dyn Fn(&Launch<'_>) -> Result<Launched, String>,
}

/// What a run produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    pub trace: Trace,
    /// A scan matcher stops at its last match: the metrics cover the steps before this one
    /// (`None`: the whole world).
    pub steps: Option<usize>,
}

/// One algorithm a study can list. Every method without a body must be written: the compiler
/// asks for each, so that no pipeline stage falls back to a default in silence.
pub trait Algorithm: Send + Sync {
    /// The name in specs, run ids and Parquet.
    fn name(&self) -> &str;
    /// The name in reports.
    fn title(&self) -> &str;
    /// One sentence on what it is, for the algorithm table (`slamlab algorithms`).
    fn summary(&self) -> Cow<'_, str>;
    /// Part of every run's content hash: bump when the algorithm's output changes.
    fn code_version(&self) -> Cow<'_, str>;
    fn role(&self) -> Role;
    /// The sensors it reads in a world of `kind`.
    fn sensors(&self, kind: WorldKind) -> Sensors;
    /// The `[base]` sections holding its own parameters (besides the world's), e.g. `fastslam`,
    /// or `external.<name>`.
    fn sections(&self, kind: WorldKind) -> Vec<String>;
    /// The report's modelling-choice sentences on it, from the parameters used.
    fn describe(&self, params: &Params, study: &Listing<'_>) -> Vec<Choice>;
    /// The work of one run (`plan::cost` turns it into expected seconds).
    fn work(&self, params: &Params, size: &RunSize) -> Work;
    /// The matcher and parameters a scan matcher's diagnostics re-run a match with (`None` for
    /// estimators and for programs slamlab cannot re-run one match of).
    fn matcher<'p>(&self, params: &'p Params) -> Option<Matcher<'p>>;
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError>;

    /// Every `[base]` section a run of it reads in a world of `kind`: the clock and odometry,
    /// the sensors it uses, and its own sections. They enter its runs' hashes.
    fn sections_read(&self, kind: WorldKind) -> Vec<String> {
        let sensors = self.sensors(kind);
        let mut s = vec!["sim".to_string(), "odometry".to_string()];
        if sensors.laser {
            s.push("laser".into());
        }
        if sensors.landmarks {
            s.push("landmark_sensor".into());
        }
        s.extend(self.sections(kind));
        s
    }

    fn is_scan_matcher(&self) -> bool {
        self.role() == Role::ScanMatcher
    }
}

/// Every built-in algorithm, in the order `slamlab algorithms` lists them.
pub fn builtins() -> Vec<Arc<dyn Algorithm>> {
    use crate::scanmatch::search::Optimizer;
    let mut all: Vec<Arc<dyn Algorithm>> = vec![
        Arc::new(filters::Odometry),
        Arc::new(filters::OdometryMap),
        Arc::new(filters::Fastslam1),
        Arc::new(filters::Fastslam2),
        Arc::new(filters::EkfSlam),
        Arc::new(filters::GraphSlam { batch: false }),
        Arc::new(filters::GraphSlam { batch: true }),
        Arc::new(matchers::Psm { own_heuristics: false }),
        Arc::new(matchers::Psm { own_heuristics: true }),
        Arc::new(matchers::Epsm),
        Arc::new(matchers::BruteForce),
        Arc::new(matchers::PlIcp),
        Arc::new(matchers::PoseGraph),
    ];
    all.extend(
        Optimizer::ALL.iter().map(|&o| Arc::new(matchers::PoseSearch(o)) as Arc<dyn Algorithm>),
    );
    all
}

/// The algorithms a study can name: the built-ins and the external programs declared for it.
#[derive(Clone)]
pub struct Catalogue {
    entries: Vec<Arc<dyn Algorithm>>,
    /// The external ones again, as declared (the entries hold them too).
    externals: Vec<Arc<external::ExternalSpec>>,
}

impl std::fmt::Debug for Catalogue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.entries.iter().map(|a| a.name())).finish()
    }
}

impl Default for Catalogue {
    fn default() -> Self {
        Self::builtin()
    }
}

impl Catalogue {
    /// The built-in algorithms alone.
    pub fn builtin() -> Catalogue {
        Catalogue { entries: builtins(), externals: Vec::new() }
    }

    /// The built-ins and `externals` (whose names the caller has checked against them).
    pub fn with_externals(externals: Vec<external::ExternalSpec>) -> Catalogue {
        let externals: Vec<Arc<external::ExternalSpec>> =
            externals.into_iter().map(Arc::new).collect();
        let mut entries = builtins();
        entries.extend(externals.iter().map(|e| Arc::clone(e) as Arc<dyn Algorithm>));
        Catalogue { entries, externals }
    }

    pub fn get(&self, name: &str) -> Option<&dyn Algorithm> {
        self.entries.iter().find(|a| a.name() == name).map(|a| a.as_ref())
    }

    /// The algorithm `id` names. Plans and stored studies hold only names the catalogue
    /// resolved, so a miss is a defect.
    pub fn algorithm(&self, id: &AlgorithmId) -> &dyn Algorithm {
        self.get(id.as_str()).unwrap_or_else(|| panic!("algorithm `{id}` is not in the catalogue"))
    }

    pub fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|a| a.name()).collect()
    }

    pub fn all(&self) -> impl Iterator<Item = &dyn Algorithm> {
        self.entries.iter().map(|a| a.as_ref())
    }

    /// The external programs among them.
    pub fn externals(&self) -> impl Iterator<Item = &external::ExternalSpec> {
        self.externals.iter().map(|e| e.as_ref())
    }

    /// The sensors any of `algorithms` reads in any of the world kinds `kinds`.
    pub fn sensors(&self, algorithms: &[AlgorithmId], kinds: &[WorldKind]) -> Sensors {
        algorithms
            .iter()
            .flat_map(|a| kinds.iter().map(move |&k| self.algorithm(a).sensors(k)))
            .fold(Sensors::NONE, Sensors::or)
    }

    /// The report's modelling-choice sentences of `algorithms`: each distinct one once, in topic
    /// order (ties in the study's order).
    pub fn choices(
        &self,
        algorithms: &[AlgorithmId],
        params: &Params,
        kinds: &[WorldKind],
    ) -> Vec<Choice> {
        let names: Vec<&str> = algorithms.iter().map(AlgorithmId::as_str).collect();
        let listing = Listing { kinds, names: &names };
        let mut out: Vec<Choice> =
            algorithms.iter().flat_map(|a| self.algorithm(a).describe(params, &listing)).collect();
        out.sort_by_key(|c| c.topic);
        let mut seen = std::collections::BTreeSet::new();
        out.retain(|c| seen.insert(c.clone()));
        out
    }
}

/// The modelling choices at the default parameters, as Markdown (the book's generated chapter
/// `reference/modelling-defaults.md`): the simulated world's sentences, then every algorithm's on
/// each kind of world it runs on — the sentences a report states for a study that keeps the
/// defaults (a study's report states them from the parameters it actually used).
pub fn modelling_defaults_markdown(catalogue: &Catalogue) -> String {
    let p = Params::default();
    let mut out = String::from("## The simulated world\n\n");
    let rate = crate::stats::sig(1.0 / p.sim.dt_s, 3);
    let world = [p.sim.describe(&rate), p.odometry.describe(), p.laser.describe()];
    let world = world.into_iter().chain(p.laser.describe_artefacts());
    for sentence in world.chain([p.landmark_sensor.describe()]) {
        out.push_str(&format!("- {sentence}\n"));
    }
    out.push_str("\n## The algorithms\n");
    for a in catalogue.all() {
        out.push_str(&format!("\n### `{}`: {}\n", a.name(), a.title()));
        let mut said: Vec<String> = Vec::new();
        for kind in WorldKind::ALL {
            let names = [a.name()];
            let listing = Listing { kinds: &[kind], names: &names };
            let sentences: Vec<String> =
                a.describe(&p, &listing).into_iter().map(|c| c.text).collect();
            if sentences.is_empty() || sentences == said {
                continue;
            }
            let world = match kind {
                WorldKind::Laser => "laser worlds",
                WorldKind::Points => "point-landmark worlds",
            };
            out.push_str(&format!("\nOn {world}:\n\n"));
            for s in &sentences {
                out.push_str(&format!("- {s}\n"));
            }
            said = sentences;
        }
    }
    out
}

/// The catalogue as a Markdown table: name, title, family, what it reads, its own `[base]`
/// sections and what it is (`slamlab algorithms --markdown`; the book's algorithm chapter, docs/src/reference/algorithms.md).
pub fn markdown_table(catalogue: &Catalogue) -> String {
    let mut out = String::from(
        "| Name | Title | Family | Reads | Own `[base]` sections | What it is |\n|---|---|---|---|---|---|\n",
    );
    for a in catalogue.all() {
        let reads = |k: WorldKind| {
            let s = a.sensors(k);
            match (s.laser, s.landmarks) {
                (false, false) => "odometry",
                (true, false) => "laser",
                (false, true) => "landmark sensor",
                (true, true) => "laser and landmark sensor",
            }
        };
        let reads = if reads(WorldKind::Laser) == reads(WorldKind::Points) {
            reads(WorldKind::Laser).to_string()
        } else {
            format!(
                "{} (laser worlds), {} (point worlds)",
                reads(WorldKind::Laser),
                reads(WorldKind::Points)
            )
        };
        let mut sections: Vec<String> = Vec::new();
        for k in WorldKind::ALL {
            for s in a.sections(k) {
                if !sections.contains(&s) {
                    sections.push(s);
                }
            }
        }
        let sections = if sections.is_empty() {
            "—".to_string()
        } else {
            sections.iter().map(|s| format!("`{s}`")).collect::<Vec<_>>().join(", ")
        };
        let family = match a.role() {
            Role::Estimator => "estimator",
            Role::ScanMatcher => "scan matcher",
        };
        out.push_str(&format!(
            "| `{}` | {} | {family} | {reads} | {sections} | {} |\n",
            a.name(),
            a.title(),
            a.summary().replace('|', "\\|")
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_has_a_distinct_name_and_resolves_to_itself() {
        let c = Catalogue::builtin();
        let names = c.names();
        assert_eq!(names.len(), 24);
        for (i, n) in names.iter().enumerate() {
            assert!(!names[..i].contains(n), "{n} is listed twice");
            assert_eq!(c.get(n).map(|a| a.name()), Some(*n));
        }
        assert!(c.get("magic").is_none());
    }

    #[test]
    fn choices_are_stated_once_in_topic_order() {
        let c = Catalogue::builtin();
        let p = Params::default();
        let ids = |n: &[&str]| n.iter().map(|s| AlgorithmId(s.to_string())).collect::<Vec<_>>();
        // FastSLAM 1.0 and 2.0 on point worlds share one sentence, EKF-SLAM adds its own, and the
        // motion model comes first, once
        let got =
            c.choices(&ids(&["ekf_slam", "fastslam2", "fastslam1"]), &p, &[WorldKind::Points]);
        let topics: Vec<Topic> = got.iter().map(|c| c.topic).collect();
        assert_eq!(topics, [Topic::MotionModel, Topic::FastslamOnPoints, Topic::Ekf]);
        assert!(got[1].text.starts_with("FastSLAM 1.0 on point worlds and 2.0"), "{}", got[1].text);
        // scan matchers share the procedure's sentences
        let got = c.choices(&ids(&["psm", "epsm"]), &p, &[WorldKind::Laser]);
        let topics: Vec<Topic> = got.iter().map(|c| c.topic).collect();
        assert_eq!(
            topics,
            [
                Topic::ScanMatching,
                Topic::ScanObjective,
                Topic::ScanSegmentation,
                Topic::Psm,
                Topic::Epsm,
                Topic::MatchErrors
            ]
        );
    }

    /// The pose graph's front ends are exactly the built-in scan matchers (itself excepted): a
    /// new matcher cannot be left out, nor a removed one named.
    #[test]
    fn the_pose_graphs_front_ends_are_the_builtin_scan_matchers() {
        let c = Catalogue::builtin();
        let mut matchers: Vec<&str> = c
            .all()
            .filter(|a| a.is_scan_matcher() && a.name() != "pose_graph")
            .map(|a| a.name())
            .collect();
        let mut front_ends = crate::slam::pose_graph::front_ends();
        matchers.sort_unstable();
        front_ends.sort_unstable();
        assert_eq!(front_ends, matchers);
    }

    #[test]
    fn scan_matchers_are_told_apart_from_estimators_and_have_a_matcher() {
        let p = Params::default();
        for a in Catalogue::builtin().all() {
            assert_eq!(a.is_scan_matcher(), a.matcher(&p).is_some(), "{}", a.name());
            assert_eq!(
                a.is_scan_matcher(),
                a.sensors(WorldKind::Points) == Sensors::LASER,
                "{}",
                a.name()
            );
        }
    }
}
