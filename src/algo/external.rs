//! External algorithms: a program in any language, declared by `data/algorithms/<name>.toml`,
//! started once per run through plain files (the protocol of docs/src/guide/external-algorithms.md). This
//! file is the protocol's pure half: the descriptor, the input files a run writes, and the
//! reading of the program's output. Starting the program is the caller's
//! ([`RunInput::launch`], `run/external.rs`): this layer does no IO.

use super::{Algorithm, Choice, Launch, Listing, Output, Role, RunInput, RunSize, Topic, Work};
use crate::geom::{Point2, Pose2, wrap_angle};
use crate::params::Params;
use crate::scanmatch::objective::Objective;
use crate::scanmatch::track::{self, Matcher};
use crate::trace::{EXTERNAL_STOP, LandmarkMap, MatchRecord, SlamError, Trace};
use crate::world::point_sensor::UNKNOWN_LANDMARK;
use crate::world::{RangeNoise, Sensors, World, WorldKind};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::fmt::Write;

/// Version of the file protocol, written into every `run.toml`.
pub const PROTOCOL: u32 = 1;

/// Part of every external run's code version: bump when what slamlab writes or reads changes.
pub const EXTERNAL_CODE_VERSION: &str = "external-2";

/// Default wall-clock limit of one run [s].
pub const DEFAULT_TIMEOUT_S: f64 = 600.0;

/// What a program reads besides the odometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reads {
    /// Range-bearing readings of point landmarks (`landmarks.txt`).
    Landmarks,
    /// Raw laser scans (`scans.txt`).
    Laser,
    /// The laser scans and the pairs slamlab's trigger chose (`scans.txt`, `pairs.txt`): the
    /// program is a scan matcher and writes one estimate per pair (`matches.txt`); slamlab chains
    /// them into the trajectory as it does its own matchers'.
    ScanPairs,
}

/// `data/algorithms/<name>.toml` as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Descriptor {
    /// The report's name for it.
    pub title: String,
    /// The program's version: part of its runs' hashes (bump when its output changes).
    pub version: String,
    /// Program and arguments; `{input}` and `{output}` become the run's folders.
    pub command: Vec<String>,
    /// Files whose bytes join the code version (the program and what it imports).
    #[serde(default)]
    pub files: Vec<String>,
    #[serde(default)]
    pub reads: Vec<Reads>,
    /// `[base]` sections it is told (`motion_model`, `ekf`, …).
    #[serde(default)]
    pub sections: Vec<String>,
    /// Wall-clock limit of one run [s].
    #[serde(default = "default_timeout")]
    pub timeout_s: f64,
    /// Expected seconds of one run, for shards and the progress line.
    #[serde(default = "default_expected")]
    pub expected_s: f64,
    /// The report's modelling-choice sentence.
    pub description: String,
}

fn default_timeout() -> f64 {
    DEFAULT_TIMEOUT_S
}

fn default_expected() -> f64 {
    1.0
}

/// An external algorithm: its descriptor, its name (the file's stem) and the blake3 of its
/// command and listed files (which the loader read).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExternalSpec {
    pub name: String,
    /// blake3 over the command and every listed file's path and bytes.
    pub content_hash: String,
    pub descriptor: Descriptor,
}

impl ExternalSpec {
    /// The content hash of a descriptor's command and of its `files` as (path, bytes).
    pub fn hash_of(descriptor: &Descriptor, files: &[(String, Vec<u8>)]) -> String {
        let mut h = blake3::Hasher::new();
        h.update(b"slamlab-external-v1\0");
        for part in &descriptor.command {
            h.update(part.as_bytes());
            h.update(b"\0");
        }
        for (path, bytes) in files {
            h.update(path.as_bytes());
            h.update(b"\0");
            h.update(&(bytes.len() as u64).to_le_bytes());
            h.update(bytes);
        }
        h.finalize().to_hex().to_string()
    }

    /// Its own parameter table's path in `[base]`.
    pub fn params_section(&self) -> String {
        format!("external.{}", self.name)
    }

    fn reads(&self, r: Reads) -> bool {
        self.descriptor.reads.contains(&r)
    }
}

/// What an estimator writes: `estimate.tum` (required) and `map.txt` (optional).
pub const OUTPUTS: &[&str] = &["estimate.tum", "map.txt"];
/// What a scan matcher writes: one estimate per pair.
pub const MATCHER_OUTPUTS: &[&str] = &["matches.txt"];

impl Algorithm for ExternalSpec {
    fn name(&self) -> &str {
        &self.name
    }
    fn title(&self) -> &str {
        &self.descriptor.title
    }
    fn summary(&self) -> Cow<'_, str> {
        format!(
            "external program (`{}`): {}",
            self.descriptor.command.join(" "),
            self.descriptor.description.trim()
        )
        .into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        let hash = &self.content_hash[..16.min(self.content_hash.len())];
        format!("{EXTERNAL_CODE_VERSION}:{}:{hash}", self.descriptor.version).into()
    }
    fn role(&self) -> Role {
        if self.reads(Reads::ScanPairs) { Role::ScanMatcher } else { Role::Estimator }
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors {
            laser: self.reads(Reads::Laser) || self.reads(Reads::ScanPairs),
            landmarks: self.reads(Reads::Landmarks),
        }
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        // a matcher's pairs follow slamlab's trigger: its settings are part of every run's inputs
        let trigger = self.reads(Reads::ScanPairs)
            && !self.descriptor.sections.iter().any(|s| s == "scan_matching");
        let mut s: Vec<String> = trigger.then(|| "scan_matching".to_string()).into_iter().collect();
        s.extend(self.descriptor.sections.iter().cloned());
        s.push(self.params_section());
        s
    }
    fn describe(&self, params: &Params, _: &Listing<'_>) -> Vec<Choice> {
        let d = &self.descriptor;
        let mut text = format!(
            "{} (external program `{}`, version {}): {}",
            d.title,
            d.command.join(" "),
            d.version,
            d.description.trim()
        );
        if let Some(own) = params.external.get(&self.name).filter(|t| !t.is_empty()) {
            let mut leaves = Vec::new();
            crate::params::flatten("", &toml::Value::Table(own.clone()), &mut leaves);
            let shown: Vec<String> = leaves.iter().map(|(k, v)| format!("{k} = {v}")).collect();
            let _ = write!(text, " Its parameters: {}.", shown.join(", "));
        }
        let mut out = vec![Choice { topic: Topic::Own, text }];
        if self.role() == Role::ScanMatcher {
            // slamlab's trigger, chaining and error measure apply to it as to its own matchers
            let sm = &params.scan_matching;
            out.push(Choice { topic: Topic::ScanMatching, text: sm.describe() });
            out.push(Choice { topic: Topic::MatchErrors, text: track::describe_errors().into() });
        }
        out
    }
    fn work(&self, _: &Params, _: &RunSize) -> Work {
        Work { external_s: self.descriptor.expected_s, ..Work::default() }
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let matcher = self.role() == Role::ScanMatcher;
        let pairs = if matcher {
            Some(track::pairs(input.world, &input.params.scan_matching)?)
        } else {
            None
        };
        let mut inputs = self.inputs(&input)?;
        if let Some((pairs, _)) = &pairs {
            // the scans the pairs name, and the pairs
            let world = input.world;
            let geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
            let steps = paired_steps(pairs);
            let paired: Vec<_> =
                world.scans.iter().filter(|s| steps.contains(&s.step)).cloned().collect();
            inputs.push(("scans.txt", crate::world::laser::scans_text(&geometry, &paired)));
            inputs.push(("pairs.txt", track::pairs_text(pairs)));
        }
        let launch = Launch {
            command: &self.descriptor.command,
            inputs,
            outputs: if matcher { MATCHER_OUTPUTS } else { OUTPUTS },
            timeout_s: self.descriptor.timeout_s,
        };
        let fail = |why: String| SlamError::External { name: self.name.clone(), why };
        let written = (input.launch)(&launch).map_err(fail)?;
        let file =
            |name: &str| written.iter().find(|(n, _)| *n == name).and_then(|(_, t)| t.as_ref());
        if let Some((pairs, steps)) = pairs {
            let Some(text) = file("matches.txt") else {
                return Err(fail("it wrote no matches.txt".into()));
            };
            let estimates = read_matches(text, &pairs).map_err(fail)?;
            let world = input.world;
            let matches = score(world, input.params, &pairs, estimates)?;
            let estimate = track::chain(world, &matches, steps);
            return Ok(Output {
                trace: Trace { estimate, matches, ..Trace::default() },
                steps: Some(steps),
            });
        }
        let Some(tum) = file("estimate.tum") else {
            return Err(fail("it wrote no estimate.tum".into()));
        };
        let steps = input.world.odometry.len();
        let estimate = read_tum(tum, steps + 1, input.world.dt_s).map_err(fail)?;
        let map = file("map.txt").map(|t| read_map(t)).transpose().map_err(fail)?;
        Ok(Output { trace: Trace { estimate, map, ..Trace::default() }, steps: None })
    }
}

impl ExternalSpec {
    /// The files of a run's input folder: `run.toml`, `odometry.txt`, and the sensor data it
    /// reads.
    pub fn inputs(&self, input: &RunInput<'_>) -> Result<Vec<(&'static str, String)>, SlamError> {
        let world = input.world;
        let mut files = vec![
            ("run.toml", self.run_toml(input)),
            ("odometry.txt", odometry_text(&world.odometry)),
        ];
        if self.reads(Reads::Landmarks) {
            files.push(("landmarks.txt", landmarks_text(world)));
        }
        if self.reads(Reads::Laser) {
            let geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
            files.push(("scans.txt", crate::world::laser::scans_text(&geometry, &world.scans)));
        }
        Ok(files)
    }

    fn run_toml(&self, input: &RunInput<'_>) -> String {
        let world = input.world;
        let start = world.truth[0];
        let mut t = toml::Table::new();
        t.insert("protocol".into(), i64::from(PROTOCOL).into());
        t.insert("algorithm".into(), self.name.clone().into());
        t.insert("run_id".into(), input.run_id.into());
        // TOML integers are signed 64-bit: the seed's lower 63 bits
        t.insert("seed".into(), ((input.seed >> 1) as i64).into());
        let kind = match input.kind {
            WorldKind::Laser => "laser",
            WorldKind::Points => "points",
        };
        t.insert("world".into(), kind.into());
        t.insert("dt_s".into(), world.dt_s.into());
        t.insert("steps".into(), (world.odometry.len() as i64).into());
        t.insert(
            "start".into(),
            toml::Value::Array(vec![start.x.into(), start.y.into(), start.theta.into()]),
        );
        if let (true, Some(noise)) = (self.reads(Reads::Landmarks), world.point_noise) {
            let model = match noise.range_noise {
                RangeNoise::Constant => "constant",
                RangeNoise::Proportional => "proportional",
                RangeNoise::Quadratic => "quadratic",
            };
            t.insert(
                "landmark_noise".into(),
                toml::Value::Table(toml::toml! {
                    range_noise = model
                    range_sigma_m = (noise.range_sigma_m)
                    bearing_sigma_rad = (noise.bearing_sigma_rad)
                }),
            );
        }
        if let (true, Some(g)) = (self.sensors(input.kind).laser, world.laser) {
            t.insert(
                "laser".into(),
                toml::Value::Table(toml::toml! {
                    angle_min_rad = (g.angle_min_rad)
                    angle_increment_rad = (g.angle_increment_rad)
                    beams = (g.beams as i64)
                    max_range_m = (g.max_range_m)
                }),
            );
        }
        t.insert(
            "base".into(),
            toml::Value::Table(input.params.sections(&self.descriptor.sections)),
        );
        let own = input.params.external.get(&self.name).cloned().unwrap_or_default();
        t.insert("params".into(), toml::Value::Table(own));
        toml::to_string(&t).expect("a run's inputs serialise to TOML")
    }
}

/// The steps of the scans `pairs` name.
fn paired_steps(pairs: &[track::Pair]) -> std::collections::BTreeSet<usize> {
    pairs.iter().flat_map(|p| [p.reference_step, p.current_step]).collect()
}

/// The match records of an external matcher's estimates, scored as every built-in matcher's are:
/// f and the valid pairs by the study's objective on scans prepared by its segmentation (the
/// common yardstick), at the estimate and at the initial guess, and the error against the true
/// pose change. A match whose estimate leaves too few pairs (f = ∞) or is not finite counts as
/// failed, as a built-in's does; the program's evaluations and time are its own and unknown.
fn score(
    world: &World,
    params: &Params,
    pairs: &[track::Pair],
    estimates: Vec<Pose2>,
) -> Result<Vec<MatchRecord>, SlamError> {
    let geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
    let sm = &params.scan_matching;
    let steps = paired_steps(pairs);
    let prepared: std::collections::BTreeMap<usize, crate::scanmatch::scan::PolarScan> = world
        .scans
        .iter()
        .filter(|s| steps.contains(&s.step))
        .map(|s| (s.step, track::prepared(s, &geometry, &sm.segmentation)))
        .collect();
    Ok(pairs
        .iter()
        .zip(estimates)
        .map(|(p, estimate)| {
            let mut cost = Objective::new(
                &prepared[&p.reference_step],
                &prepared[&p.current_step],
                &sm.objective,
            );
            let (f, valid) =
                if estimate.is_finite() { cost.f_and_pairs(estimate) } else { (f64::NAN, 0) };
            MatchRecord {
                reference_step: p.reference_step,
                current_step: p.current_step,
                truth: world.truth[p.current_step].relative_to(world.truth[p.reference_step]),
                initial: p.initial,
                estimate,
                f,
                f_initial: cost.f_and_pairs(p.initial).0,
                pairs: valid as u32,
                iterations: 0,
                evaluations: 0,
                fallback: false,
                stop: EXTERNAL_STOP.into(),
                time_s: f64::NAN,
            }
        })
        .collect())
}

/// `odometry.txt`: line k is the increment uₖ from pose k to pose k + 1 in the robot frame of
/// pose k, reals in Rust's shortest round-trip form.
pub fn odometry_text(odometry: &[Pose2]) -> String {
    let mut s = String::from("# step dx_m dy_m dtheta_rad\n");
    for (k, u) in odometry.iter().enumerate() {
        let _ = writeln!(s, "{k} {} {} {}", u.x, u.y, u.theta);
    }
    s
}

/// `landmarks.txt`: one range-bearing reading a line, `step range_m bearing_rad id` (`-1`: the
/// sensor reports no identity).
pub fn landmarks_text(world: &World) -> String {
    let mut s = String::from("# step range_m bearing_rad id (-1 = no identity)\n");
    for scan in &world.point_scans {
        for o in &scan.observations {
            let id = if o.landmark == UNKNOWN_LANDMARK { -1 } else { o.landmark as i64 };
            let _ = writeln!(s, "{} {} {} {id}", scan.step, o.range_m, o.bearing_rad);
        }
    }
    s
}

/// The data lines of a text file: (line number, fields), comments and blank lines skipped.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, Vec<&str>)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
        .map(|(n, l)| (n, l.split_whitespace().collect()))
}

fn number(file: &str, line: usize, field: &str) -> Result<f64, String> {
    field.parse::<f64>().map_err(|_| format!("{file} line {line}: `{field}` is not a number"))
}

/// The poses of a TUM file of planar poses: `expected` lines at t = k·`dt_s` (to 1 ms), z, qx
/// and qy zero, heading θ = 2 atan2(qz, qw).
pub fn read_tum(text: &str, expected: usize, dt_s: f64) -> Result<Vec<Pose2>, String> {
    let mut poses = Vec::with_capacity(expected);
    for (line, fields) in data_lines(text) {
        if fields.len() != 8 {
            return Err(format!(
                "estimate.tum line {line}: expected 8 numbers (t x y z qx qy qz qw), got {}",
                fields.len()
            ));
        }
        let v = fields
            .iter()
            .map(|f| number("estimate.tum", line, f))
            .collect::<Result<Vec<f64>, _>>()?;
        let k = poses.len();
        if (v[0] - k as f64 * dt_s).abs() > 1e-3 {
            return Err(format!(
                "estimate.tum line {line}: timestamp {} is not that of step {k} ({})",
                v[0],
                k as f64 * dt_s
            ));
        }
        if v[3..6].iter().any(|c| c.abs() > 1e-9) {
            return Err(format!(
                "estimate.tum line {line}: z, qx and qy must be 0 (a planar pose)"
            ));
        }
        poses.push(Pose2::new(v[1], v[2], wrap_angle(2.0 * v[6].atan2(v[7]))));
    }
    if poses.len() != expected {
        return Err(format!(
            "estimate.tum has {} poses, expected {expected} (one per step, steps + 1)",
            poses.len()
        ));
    }
    Ok(poses)
}

/// `matches.txt`: one line per pair of `pairs.txt`, in order, `ref_step cur_step x_m y_m
/// theta_rad` — the current scan's pose in the reference scan's frame (`nan` where the match
/// failed: the chain then follows the initial guess).
pub fn read_matches(text: &str, pairs: &[track::Pair]) -> Result<Vec<Pose2>, String> {
    let mut out = Vec::with_capacity(pairs.len());
    for (line, fields) in data_lines(text) {
        if fields.len() != 5 {
            return Err(format!(
                "matches.txt line {line}: expected 5 fields (ref_step cur_step x y theta), got {}",
                fields.len()
            ));
        }
        let Some(pair) = pairs.get(out.len()) else {
            return Err(format!(
                "matches.txt line {line}: more matches than the {} pairs",
                pairs.len()
            ));
        };
        let steps = (fields[0].parse::<usize>(), fields[1].parse::<usize>());
        if steps != (Ok(pair.reference_step), Ok(pair.current_step)) {
            return Err(format!(
                "matches.txt line {line}: expected the pair {} {} (pairs.txt's order), got {} {}",
                pair.reference_step, pair.current_step, fields[0], fields[1]
            ));
        }
        let v = fields[2..]
            .iter()
            .map(|f| number("matches.txt", line, f))
            .collect::<Result<Vec<f64>, _>>()?;
        // headings in (−π, π], as slamlab's own matchers give them
        out.push(Pose2::new(v[0], v[1], if v[2].is_finite() { wrap_angle(v[2]) } else { v[2] }));
    }
    if out.len() != pairs.len() {
        return Err(format!(
            "matches.txt has {} matches, expected one per pair ({})",
            out.len(),
            pairs.len()
        ));
    }
    Ok(out)
}

/// `map.txt`: one point landmark a line, `x y` or `x y id`.
pub fn read_map(text: &str) -> Result<LandmarkMap, String> {
    let mut map = LandmarkMap::default();
    for (line, fields) in data_lines(text) {
        if !(2..=3).contains(&fields.len()) {
            return Err(format!(
                "map.txt line {line}: expected `x y` or `x y id`, got {} fields",
                fields.len()
            ));
        }
        map.points.push(Point2::new(
            number("map.txt", line, fields[0])?,
            number("map.txt", line, fields[1])?,
        ));
        let id = match fields.get(2) {
            None => None,
            Some(f) => {
                let id: i64 = f
                    .parse()
                    .map_err(|_| format!("map.txt line {line}: id `{f}` is not an integer"))?;
                usize::try_from(id).ok()
            }
        };
        map.point_ids.push(id);
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tum_poses_read_back_to_the_writers_precision() {
        let poses = [Pose2::new(1.0, -2.0, 3.0), Pose2::new(0.5, 0.25, -1.2)];
        let text = crate::store::tum::tum_text(0.1, &poses, &|_| true);
        let back = read_tum(&text, 2, 0.1).unwrap();
        for (a, b) in poses.iter().zip(&back) {
            assert!((a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9);
            assert!(wrap_angle(a.theta - b.theta).abs() < 1e-11);
        }
    }

    #[test]
    fn malformed_tum_names_the_line_and_the_fault() {
        let e = read_tum("0 0 0 0 0 0 0 1\n0.1 1 2 0 0 0\n", 2, 0.1).unwrap_err();
        assert!(e.contains("line 2") && e.contains("expected 8 numbers"), "{e}");
        let e = read_tum("0 0 0 0 0 0 0 1\n0.1 1 x 0 0 0 0 1\n", 2, 0.1).unwrap_err();
        assert!(e.contains("line 2") && e.contains("`x` is not a number"), "{e}");
        let e = read_tum("0 0 0 0 0 0 0 1\n", 3, 0.1).unwrap_err();
        assert!(e.contains("has 1 poses, expected 3"), "{e}");
        let e = read_tum("# header\n0 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n", 2, 0.1).unwrap_err();
        assert!(e.contains("line 3") && e.contains("timestamp 0.5"), "{e}");
        let e = read_tum("0 0 0 1 0 0 0 1\n", 1, 0.1).unwrap_err();
        assert!(e.contains("planar"), "{e}");
    }

    #[test]
    fn a_map_keeps_identities_where_given() {
        let m = read_map("# x y id\n1 2 7\n3.5 4\n5 6 -1\n").unwrap();
        assert_eq!(m.points, [Point2::new(1.0, 2.0), Point2::new(3.5, 4.0), Point2::new(5.0, 6.0)]);
        assert_eq!(m.point_ids, [Some(7), None, None]);
        assert!(read_map("1 2 3 4\n").unwrap_err().contains("line 1"));
    }

    #[test]
    fn a_matcher_answers_each_pair_in_order() {
        let pair =
            |r, c| track::Pair { reference_step: r, current_step: c, initial: Pose2::IDENTITY };
        let pairs = [pair(0, 5), pair(5, 9)];
        let m =
            read_matches("# ref cur x y theta\n0 5 0.5 0 0.1\n5 9 nan nan nan\n", &pairs).unwrap();
        assert_eq!(m[0], Pose2::new(0.5, 0.0, 0.1));
        assert!(!m[1].is_finite(), "a failed match is NaN: the chain follows the initial guess");
        let e = read_matches("0 5 0.5 0 0.1\n", &pairs).unwrap_err();
        assert!(e.contains("has 1 matches, expected one per pair (2)"), "{e}");
        let e = read_matches("0 5 0.5 0 0.1\n5 8 0 0 0\n", &pairs).unwrap_err();
        assert!(e.contains("line 2") && e.contains("expected the pair 5 9"), "{e}");
    }

    #[test]
    fn odometry_reads_back_bit_for_bit() {
        let u = [Pose2::new(0.1 + 0.2, -1e-17, 1.0 / 3.0)];
        let text = odometry_text(&u);
        let f: Vec<f64> =
            text.lines().nth(1).unwrap().split(' ').skip(1).map(|v| v.parse().unwrap()).collect();
        assert_eq!(f, [u[0].x, u[0].y, u[0].theta]);
    }
}
