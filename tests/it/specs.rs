//! Contract: every study in experiments/ parses, validates and plans against data/maps.

use crate::util::repo;
use slamlab::{plan, spec};

#[test]
fn every_experiment_validates_and_plans() {
    let dir = repo().join("experiments");
    let mut specs: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    specs.sort();
    assert!(specs.len() >= 3, "expected the example studies in {}", dir.display());
    let mut ids = Vec::new();
    for path in specs {
        let loaded = spec::load(&path, &crate::util::catalogue()).unwrap_or_else(|e| panic!("{e}"));
        // the file is named after the study
        assert_eq!(
            path.file_stem().unwrap().to_str().unwrap(),
            loaded.spec.id,
            "{}",
            path.display()
        );
        let plan = plan::build(loaded, &repo().join("data/maps")).unwrap_or_else(|e| panic!("{e}"));
        assert!(!plan.runs.is_empty());
        assert_eq!(
            plan.runs.len(),
            plan.maps.len()
                * plan.spec.spec.algorithms.len()
                * plan.points.len()
                * plan.spec.spec.replicate_budget() as usize,
            "{}: a sequential study plans its whole budget",
            plan.id()
        );
        ids.push(plan.id().to_string());
    }
    let before = ids.len();
    ids.sort();
    ids.dedup();
    assert_eq!(ids.len(), before, "study ids must be unique");
}

#[test]
fn odometry_noise_study_covers_the_five_thesis_maps() {
    let loaded =
        spec::load(&repo().join("experiments/odometry-noise.toml"), &crate::util::catalogue())
            .unwrap();
    assert_eq!(
        loaded.spec.maps,
        ["recinto_basico", "lineamedia", "bigloop", "bigloop2", "complex"]
    );
    assert!(loaded.sweeps.iter().flat_map(|b| &b.params).any(|p| p.path == "odometry.k"));
}

#[test]
fn a_fixed_world_study_varies_only_the_filter_seeds() {
    // [PF]'s design: the same odometry and map in all 20 runs, only the filter's randomness varies
    let loaded =
        spec::load(&repo().join("experiments/pf-particles.toml"), &crate::util::catalogue())
            .unwrap();
    assert!(loaded.spec.fixed_world);
    let plan = plan::build(loaded, &repo().join("data/maps")).unwrap();
    let world: std::collections::BTreeSet<u64> = plan.runs.iter().map(|r| r.world_seed).collect();
    let filter: std::collections::BTreeSet<u64> = plan.runs.iter().map(|r| r.filter_seed).collect();
    assert_eq!(world.len(), 1, "one world for every replicate");
    assert_eq!(
        filter.len(),
        plan.spec.spec.replicate_budget() as usize,
        "a filter seed per replicate"
    );
    // and a study without the flag draws a world per replicate
    let other = plan::build(
        spec::load(&repo().join("experiments/pf-neff-p0.toml"), &crate::util::catalogue()).unwrap(),
        &repo().join("data/maps"),
    )
    .unwrap();
    let worlds: std::collections::BTreeSet<u64> = other.runs.iter().map(|r| r.world_seed).collect();
    assert_eq!(worlds.len(), other.spec.spec.replicate_budget() as usize);
}
