//! A FastSLAM particle: a pose hypothesis and its own landmark map — one 2 × 2 EKF per landmark
//! ([FT] Eq. 3.7). Maps are shared copy-on-write between particles (`Arc`): resampling copies
//! pointers, and a particle that changes a map it shares copies the map's block pointers and only
//! the blocks of 64 landmarks it changes ([`Blocks`]).

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

/// A particle's map: lines and corners kept apart (association only compares like with like),
/// and for each list an index from landmark identity to the first landmark created from it, so
/// that known association finds a landmark in O(1) rather than by a search of the map. Landmarks
/// are only ever added ([`Map::push`]), and a landmark's identity never changes, so the index
/// stays that of the first.
///
/// Every list is stored in shared blocks of [`BLOCK`] entries (copy-on-write, like FastSLAM's
/// tree of landmarks shared between particles, Montemerlo et al. 2002 §4): copying a map — a
/// particle that changes a map it shares after resampling — copies K / `BLOCK` pointers, and
/// changing a landmark copies the one block that holds it, not the K landmarks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Map {
    lines: Blocks<Landmark>,
    corners: Blocks<Landmark>,
    /// Per list (lines, corners): `index[id]` = 1 + the first landmark with identity `id`, or 0.
    index: [Blocks<u32>; 2],
}

/// Entries per shared block of a [`Map`]'s lists: a change copies one block (64 landmarks, 4 KiB),
/// a map copy K / 64 pointers.
pub const BLOCK: usize = 64;

/// A list stored in shared blocks of [`BLOCK`] entries (all full but the last), copied on write
/// one block at a time. Indexing and iteration are those of the list.
#[derive(Debug, Clone, PartialEq)]
pub struct Blocks<T> {
    blocks: Vec<Arc<Vec<T>>>,
    len: usize,
}

impl<T> Default for Blocks<T> {
    fn default() -> Self {
        Self { blocks: Vec::new(), len: 0 }
    }
}

impl<T: Clone> Blocks<T> {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn get(&self, k: usize) -> Option<&T> {
        (k < self.len).then(|| &self.blocks[k / BLOCK][k % BLOCK])
    }

    /// Entry `k` for writing: its block is copied first if another list shares it.
    pub fn get_mut(&mut self, k: usize) -> Option<&mut T> {
        (k < self.len).then(|| &mut Arc::make_mut(&mut self.blocks[k / BLOCK])[k % BLOCK])
    }

    pub fn iter(&self) -> impl Iterator<Item = &T> + '_ {
        self.blocks.iter().flat_map(|b| b.iter())
    }

    pub fn push(&mut self, value: T) {
        match self.blocks.last_mut() {
            Some(last) if last.len() < BLOCK => Arc::make_mut(last).push(value),
            _ => self.blocks.push(Arc::new({
                let mut block = Vec::with_capacity(BLOCK);
                block.push(value);
                block
            })),
        }
        self.len += 1;
    }
}

impl<T: Clone> std::ops::Index<usize> for Blocks<T> {
    type Output = T;
    fn index(&self, k: usize) -> &T {
        self.get(k).unwrap_or_else(|| panic!("index {k} out of a list of {}", self.len))
    }
}

impl<T: Clone> std::ops::IndexMut<usize> for Blocks<T> {
    fn index_mut(&mut self, k: usize) -> &mut T {
        let len = self.len;
        self.get_mut(k).unwrap_or_else(|| panic!("index {k} out of a list of {len}"))
    }
}

/// Identities at or above this are not indexed (the index is a list as long as the largest
/// identity) and are found by searching the list: every dataset's identities are landmark
/// numbers, far below it.
const INDEXED_IDS: usize = 1 << 24;

impl Map {
    fn slot(model: Model) -> usize {
        match model {
            Model::Line => 0,
            Model::Point => 1,
        }
    }

    pub fn of(&self, model: Model) -> &Blocks<Landmark> {
        match model {
            Model::Line => &self.lines,
            Model::Point => &self.corners,
        }
    }

    /// The landmarks of one list, for updating in place (adding goes through [`Map::push`]);
    /// indexing copies the landmark's block first if another map shares it.
    pub fn of_mut(&mut self, model: Model) -> &mut Blocks<Landmark> {
        match model {
            Model::Line => &mut self.lines,
            Model::Point => &mut self.corners,
        }
    }

    pub fn lines(&self) -> &Blocks<Landmark> {
        &self.lines
    }

    pub fn corners(&self) -> &Blocks<Landmark> {
        &self.corners
    }

    /// Adds a landmark to `model`'s list.
    pub fn push(&mut self, model: Model, landmark: Landmark) {
        let list = match model {
            Model::Line => &mut self.lines,
            Model::Point => &mut self.corners,
        };
        if let Some(id) = landmark.id.filter(|&id| id < INDEXED_IDS) {
            let index = &mut self.index[Self::slot(model)];
            while index.len() <= id {
                index.push(0);
            }
            if index[id] == 0 {
                index[id] = list.len() as u32 + 1;
            }
        }
        list.push(landmark);
    }

    /// The first landmark of `model`'s list created from identity `id`.
    pub fn find_id(&self, model: Model, id: usize) -> Option<usize> {
        if id >= INDEXED_IDS {
            return self.of(model).iter().position(|l| l.id == Some(id));
        }
        let at = *self.index[Self::slot(model)].get(id)?;
        (at > 0).then(|| at as usize - 1)
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
    /// Σ_t log w_t along the particle's lineage ([PF] Eq. 20): inherited from the ancestor at
    /// resampling, never normalised or reset.
    pub lineage_log_weight: f64,
    pub map: Arc<Map>,
    /// The particle's past poses (shared with its relatives: copy-on-write ancestry), recorded
    /// only when the filter reports a particle's path.
    pub path: Path,
}

impl Particle {
    pub fn new(pose: Pose2) -> Self {
        Self {
            pose,
            log_weight: 0.0,
            lineage_log_weight: 0.0,
            map: Arc::new(Map::default()),
            path: Path::default(),
        }
    }

    /// The map for writing: copied first if another particle shares it.
    pub fn map_mut(&mut self) -> &mut Map {
        Arc::make_mut(&mut self.map)
    }
}

/// A particle's path: a persistent list of poses, newest first, whose older part is shared by
/// every descendant of one ancestor (resampling copies a pointer, not the path).
#[derive(Debug, Clone, Default)]
pub struct Path(Option<Arc<PathNode>>);

#[derive(Debug)]
pub struct PathNode {
    pose: Pose2,
    parent: Option<Arc<PathNode>>,
}

impl Path {
    /// Appends the pose of the current step.
    pub fn push(&mut self, pose: Pose2) {
        self.0 = Some(Arc::new(PathNode { pose, parent: self.0.take() }));
    }

    /// The poses, oldest first.
    pub fn poses(&self) -> Vec<Pose2> {
        let mut out = Vec::new();
        let mut node = self.0.as_deref();
        while let Some(n) = node {
            out.push(n.pose);
            node = n.parent.as_deref();
        }
        out.reverse();
        out
    }
}

impl Drop for PathNode {
    /// Frees a long unshared chain iteratively (a recursive drop of thousands of nodes could
    /// overflow a worker thread's stack); stops at the first node another path still holds.
    fn drop(&mut self) {
        let mut next = self.parent.take();
        while let Some(node) = next {
            match Arc::try_unwrap(node) {
                Ok(mut n) => next = n.parent.take(),
                Err(_) => break,
            }
        }
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
pub fn resampled(
    particles: &[Particle],
    ancestors: &[usize],
    best: usize,
) -> (Vec<Particle>, usize) {
    let best = ancestors.iter().position(|&a| a == best).unwrap_or(0);
    (
        ancestors.iter().map(|&a| Particle { log_weight: 0.0, ..particles[a].clone() }).collect(),
        best,
    )
}

/// Index of the largest weight (the first on ties).
pub fn argmax(w: &[f64]) -> usize {
    w.iter().enumerate().fold(0, |best, (i, &x)| if x > w[best] { i } else { best })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block list behaves as a list (push, index, change, iterate) under random operations,
    /// and a copy shares every block until one changes: then only that block is copied.
    #[test]
    fn blocks_are_a_list_shared_block_by_block() {
        let (mut list, mut plain) = (Blocks::<u64>::default(), Vec::<u64>::new());
        let mut x = 1u64;
        for step in 0..5_000u64 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            if plain.is_empty() || x % 3 == 0 {
                list.push(step);
                plain.push(step);
            } else {
                let k = (x >> 33) as usize % plain.len();
                list[k] += 7;
                plain[k] += 7;
            }
        }
        assert_eq!(list.len(), plain.len());
        assert!(list.iter().copied().eq(plain.iter().copied()));
        assert!((0..plain.len()).all(|k| list[k] == plain[k] && list.get(k) == Some(&plain[k])));
        assert_eq!(list.get(plain.len()), None);
        let mut copy = list.clone();
        copy[BLOCK + 1] = 0;
        let shared = list.blocks.iter().zip(&copy.blocks).filter(|(a, b)| Arc::ptr_eq(a, b));
        assert_eq!(shared.count(), list.blocks.len() - 1, "only the changed block is copied");
        assert_eq!(list[BLOCK + 1], plain[BLOCK + 1], "the original is unchanged");
    }

    /// Maps find a landmark by identity whatever the block it sits in, the first one created from
    /// an identity wins, and a copy's change does not reach the original.
    #[test]
    fn map_identity_index_across_blocks_and_copies() {
        let mut map = Map::default();
        let at = |k: usize| Landmark {
            id: Some(3 * k),
            ..Landmark::new(Vector2::new(k as f64, 0.0), Matrix2::identity())
        };
        for k in 0..300 {
            map.push(Model::Point, at(k));
        }
        map.push(Model::Point, Landmark { mean: Vector2::new(-1.0, 0.0), ..at(5) });
        assert_eq!(map.find_id(Model::Point, 15), Some(5));
        assert_eq!(map.find_id(Model::Point, 3 * 299), Some(299));
        assert_eq!((map.find_id(Model::Point, 16), map.find_id(Model::Line, 15)), (None, None));
        let mut copy = map.clone();
        copy.of_mut(Model::Point)[200].mean[1] = 9.0;
        assert_eq!((map.corners()[200].mean[1], copy.corners()[200].mean[1]), (0.0, 9.0));
    }

    /// Copies share their ancestry: two descendants of one particle see its past, then their
    /// own steps; a path of 100 000 poses drops without recursion.
    #[test]
    fn paths_share_their_ancestry() {
        let mut a = Particle::new(Pose2::IDENTITY);
        a.path.push(Pose2::new(0.0, 0.0, 0.0));
        a.path.push(Pose2::new(1.0, 0.0, 0.0));
        let mut b = a.clone();
        a.path.push(Pose2::new(2.0, 0.0, 0.0));
        b.path.push(Pose2::new(2.0, 1.0, 0.0));
        assert_eq!(a.path.poses().iter().map(|p| p.y).collect::<Vec<_>>(), vec![0.0, 0.0, 0.0]);
        assert_eq!(
            b.path.poses().iter().map(|p| (p.x, p.y)).collect::<Vec<_>>(),
            vec![(0.0, 0.0), (1.0, 0.0), (2.0, 1.0)]
        );
        let mut long = Path::default();
        for k in 0..100_000 {
            long.push(Pose2::new(k as f64, 0.0, 0.0));
        }
        drop(long);
    }

    #[test]
    fn resampled_copies_share_their_map_until_one_writes() {
        let mut a = Particle::new(Pose2::IDENTITY);
        a.map_mut().push(Model::Line, Landmark::new(Vector2::new(1.0, 0.0), Matrix2::identity()));
        let mut b = a.clone();
        assert!(Arc::ptr_eq(&a.map, &b.map), "a copy shares the map");
        b.map_mut().of_mut(Model::Line)[0].mean[0] = 2.0;
        assert!(!Arc::ptr_eq(&a.map, &b.map));
        assert_eq!(a.map.lines()[0].mean[0], 1.0, "the original is untouched");
    }
}
