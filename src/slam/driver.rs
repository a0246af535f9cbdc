//! The one filter loop every SLAM filter runs ([FT] Table 6.3, [PR] Table 10.1, [EV] steps 0–3
//! share it): for each odometry step k = 0 … K, predict with the increment uₖ₋₁ (none at step 0),
//! then update with that step's observations zₖ, and record what the trace keeps. A filter
//! supplies the step and the trace; the driver owns the walk through the odometry and the
//! observation stream, so that every filter reads them the same way.

use super::observations::{Cursor, Observation, StepObservations};
use super::{SlamError, Trace};
use crate::geom::Pose2;
use crate::world::World;

/// A filter the driver steps through a world.
pub trait Filter {
    /// Odometry step `k`: predict with `control` (uₖ₋₁; `None` at step 0), update with
    /// `observations` (zₖ), and record the step. An error stops the run.
    fn step(
        &mut self,
        k: usize,
        control: Option<&Pose2>,
        observations: &[Observation],
    ) -> Result<(), SlamError>;

    /// The trace once every step has run.
    fn finish(self) -> Trace;
}

/// Runs `filter` over every step of `world`, reading `observations` in step order
/// (`known_association`: several readings of one identity in a step arrive fused into one).
pub fn run(
    world: &World,
    observations: &[StepObservations],
    known_association: bool,
    mut filter: impl Filter,
) -> Result<Trace, SlamError> {
    let mut cursor = Cursor::new(observations, known_association);
    for k in 0..=world.odometry.len() {
        let control = k.checked_sub(1).map(|j| &world.odometry[j]);
        filter.step(k, control, cursor.at(k))?;
    }
    Ok(filter.finish())
}
