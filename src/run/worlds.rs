//! Worlds shared by the runs that see the same one. A run's world depends on its map, its world
//! seed and the parameters world generation reads (`sim`, `odometry`, and the sections of the
//! sensors its algorithm uses) — not on the swept filter parameters (particles, P0, Neff, the
//! filters' noise models) nor on the algorithm beyond its sensors. So every particle count, P0
//! or Neff point of a study, and every algorithm with the same sensors, sees the same world for
//! a given map and replicate: it is generated (or a dataset read) once, and dropped when the last
//! run that needs it has finished. Likewise the features extracted from its laser scans: every
//! run on that world with the same `[features]` parameters uses one extraction.

use super::{SimError, world_of};
use crate::features::{FeatureParams, ScanFeatures};
use crate::plan::{ExperimentPlan, RunSpec};
use crate::slam::SlamError;
use crate::world::World;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// A world, or why it could not be made (the message of its [`SimError`]).
pub type Shared = Result<Arc<SharedWorld>, String>;

/// A world and what has been extracted from it.
pub struct SharedWorld {
    pub world: World,
    /// Features of every scan, per `[features]` parameters (as JSON).
    extracted: Mutex<HashMap<String, Arc<OnceLock<Arc<Vec<ScanFeatures>>>>>>,
}

impl SharedWorld {
    pub fn new(world: World) -> Self {
        Self { world, extracted: Mutex::new(HashMap::new()) }
    }

    /// The features of every laser scan with `params`, extracted by the first run that asks.
    pub fn features(&self, params: &FeatureParams) -> Result<Arc<Vec<ScanFeatures>>, SlamError> {
        if self.world.laser.is_none() {
            return Err(SlamError::MissingSensor("laser"));
        }
        let cell = Arc::clone(
            self.extracted
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .entry(serde_json::to_string(params).expect("parameters serialise"))
                .or_default(),
        );
        Ok(Arc::clone(cell.get_or_init(|| {
            Arc::new(
                crate::slam::observations::extract_all(&self.world, params)
                    .expect("the world has a laser"),
            )
        })))
    }
}

/// A run's world on its own (not shared).
pub fn alone(plan: &ExperimentPlan, run: &RunSpec) -> Shared {
    world_of(plan, run).map(|w| Arc::new(SharedWorld::new(w))).map_err(|e: SimError| e.to_string())
}

struct Slot {
    world: Arc<OnceLock<Shared>>,
    /// Runs still to take it.
    users: usize,
}

/// The worlds of one batch of runs.
pub struct Worlds<'p> {
    plan: &'p ExperimentPlan,
    slots: Mutex<HashMap<String, Slot>>,
}

/// Everything [`world_of`] reads for `run`, as a string: equal keys, equal worlds.
pub fn key(plan: &ExperimentPlan, run: &RunSpec) -> String {
    let params = &plan.points[run.point].params;
    let sensors = plan.algorithm(run).sensors(plan.maps[run.map].world_kind());
    // one buffer, sized once (a plan of 10⁵ runs keys every run twice before the first starts)
    let mut key = Vec::with_capacity(1024);
    key.extend_from_slice(format!("{}\u{1f}{}", run.map, run.world_seed).as_bytes());
    json(&mut key, &params.sim);
    json(&mut key, &params.odometry);
    if sensors.laser {
        json(&mut key, &params.laser);
    } else {
        key.push(0x1f);
    }
    if sensors.landmarks {
        json(&mut key, &params.landmark_sensor);
    } else {
        key.push(0x1f);
    }
    String::from_utf8(key).expect("JSON is UTF-8")
}

/// Appends a separator and a parameter section as JSON (part of a key).
fn json(key: &mut Vec<u8>, section: &impl serde::Serialize) {
    key.push(0x1f);
    serde_json::to_writer(&mut *key, section).expect("parameters serialise");
}

impl<'p> Worlds<'p> {
    /// The worlds the runs `todo` (indices into `plan.runs`) need, none made yet.
    pub fn new(plan: &'p ExperimentPlan, todo: &[usize]) -> Self {
        let mut slots: HashMap<String, Slot> = HashMap::new();
        for &i in todo {
            slots
                .entry(key(plan, &plan.runs[i]))
                .or_insert_with(|| Slot { world: Arc::new(OnceLock::new()), users: 0 })
                .users += 1;
        }
        Self { plan, slots: Mutex::new(slots) }
    }

    /// The world of `run`, made by the first run that asks (the others asking meanwhile wait for
    /// it). Each run of the batch takes its world exactly once; after the last one, it is freed.
    pub fn take(&self, run: &RunSpec) -> Shared {
        let key = key(self.plan, run);
        let cell = {
            let mut slots = self.slots.lock().unwrap_or_else(|e| e.into_inner());
            let Some(slot) = slots.get_mut(&key) else {
                // not planned in this batch: make it on its own
                return alone(self.plan, run);
            };
            slot.users -= 1;
            let cell = Arc::clone(&slot.world);
            if slot.users == 0 {
                slots.remove(&key);
            }
            cell
        };
        cell.get_or_init(|| alone(self.plan, run)).clone()
    }

    /// Worlds still held (for tests).
    pub fn held(&self) -> usize {
        self.slots.lock().unwrap_or_else(|e| e.into_inner()).len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(spec: &str) -> ExperimentPlan {
        crate::plan::build(
            crate::spec::load(std::path::Path::new(spec), &Default::default()).expect("spec loads"),
            std::path::Path::new("data/maps"),
        )
        .expect("spec plans")
    }

    #[test]
    fn the_p0_points_of_a_replicate_share_one_world_and_one_extraction() {
        let p = plan("experiments/ft-p0.toml");
        let todo: Vec<usize> = (0..p.runs.len()).collect();
        let keys: std::collections::BTreeSet<String> = p.runs.iter().map(|r| key(&p, r)).collect();
        assert_eq!(
            keys.len(),
            p.spec.spec.replicates as usize,
            "one world per replicate: P0 is no world parameter"
        );
        let worlds = Worlds::new(&p, &todo);
        let of = |replicate: u32, point: usize| {
            p.runs.iter().position(|r| r.replicate == replicate && r.point == point).unwrap()
        };
        let (a, b, other) = (
            worlds.take(&p.runs[of(0, 0)]).unwrap(),
            worlds.take(&p.runs[of(0, 3)]).unwrap(),
            worlds.take(&p.runs[of(1, 0)]).unwrap(),
        );
        assert!(Arc::ptr_eq(&a, &b), "two P0 points of replicate 0 see one world");
        assert!(!Arc::ptr_eq(&a, &other), "replicate 1 sees its own");
        let params = &p.points[0].params.features;
        assert!(
            Arc::ptr_eq(&a.features(params).unwrap(), &b.features(params).unwrap()),
            "one extraction"
        );
        // the shared world is the one `world_of` makes for the run alone
        let alone = world_of(&p, &p.runs[of(0, 3)]).unwrap();
        assert_eq!(
            (alone.truth.clone(), alone.odometry.clone(), alone.scans.len()),
            (b.world.truth.clone(), b.world.odometry.clone(), b.world.scans.len())
        );
        assert!(alone.scans.iter().zip(&b.world.scans).all(|(x, y)| x.ranges_m == y.ranges_m));
        // every run takes its world once; after the last, nothing is held
        for (i, r) in p.runs.iter().enumerate() {
            if ![of(0, 0), of(0, 3), of(1, 0)].contains(&i) {
                worlds.take(r).unwrap();
            }
        }
        assert_eq!(worlds.held(), 0);
    }

    #[test]
    fn the_schedule_keeps_a_worlds_runs_together_dearest_first() {
        let p = plan("experiments/ft-particles.toml");
        let todo: Vec<usize> = (0..p.runs.len()).collect();
        let cost = |i: usize| crate::plan::cost::expected_s(&p, &p.runs[i]);
        let order = crate::run::schedule(&p, &todo, &cost);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, todo, "every run once");
        // runs of one world are consecutive
        let keys: Vec<String> = order.iter().map(|&i| key(&p, &p.runs[i])).collect();
        let mut seen = std::collections::BTreeSet::new();
        for w in keys.windows(2) {
            if w[0] != w[1] {
                assert!(seen.insert(w[0].clone()), "a world's runs are split");
            }
        }
        // the first run is the dearest of all (500 particles on Complex)
        let first = &p.runs[order[0]];
        assert!(todo.iter().all(|&i| cost(i) <= cost(order[0])), "{}", first.run_id);
    }
}
