//! Contract: the laser pose graph closes loops on real scans. On the Intel lab log with its exact
//! corrected increments as the guesses and no odometry edges (so every correction comes from the
//! scans), the pose graph on PL-ICP finds loop closures, few of them wrong, and its trajectory is
//! closer to the corrected poses than PL-ICP's chained matches. The bounds were set before the
//! test first ran: at least 100 closures, at most 10 % wrong (0.2 m or 5°), a lower ATE.
//! Skipped with a message when `../shared/data/intel-lab` is absent.

use crate::util::repo;
use slamlab::dataset::intel_lab;
use slamlab::metrics::{ATE_RMSE, loop_closure_metrics, trajectory_metrics};
use slamlab::scanmatch::plicp::PlIcpParams;
use slamlab::scanmatch::track::{self, Matcher, ScanMatchingParams};
use slamlab::slam::graph::GraphParams;
use slamlab::slam::motion::MotionModel;
use slamlab::slam::pose_graph::{PoseGraphParams, pose_graph};

#[test]
fn the_pose_graph_closes_loops_on_the_intel_log() {
    let folder = repo().join("../shared/data/intel-lab");
    if !folder.is_dir() {
        eprintln!("skipped: pose_graph: ../shared/data/intel-lab is absent");
        return;
    }
    let world = intel_lab::load(&folder, 0, 0, intel_lab::DEFAULT_MAX_RANGE_M).unwrap();
    let scan_matching = ScanMatchingParams {
        trigger_distance_m: 0.001,
        trigger_angle_deg: 1.0,
        ..ScanMatchingParams::default()
    };
    let plicp = PlIcpParams::default();
    let matcher = Matcher::PlIcp(&plicp);
    let mut clock = || 0.0;
    let chained = track::track(&world, matcher, &scan_matching, 1, &mut clock).unwrap();
    let params = PoseGraphParams { odometry_edges: false, ..PoseGraphParams::default() };
    let graph = pose_graph(
        &world,
        matcher,
        &scan_matching,
        &params,
        &GraphParams::default(),
        &MotionModel::default(),
        1,
        &mut clock,
    )
    .unwrap();
    let ate = |estimate: &[slamlab::geom::Pose2]| {
        let m = trajectory_metrics(&world.truth[..estimate.len()], estimate);
        m.iter().find(|(k, _)| *k == ATE_RMSE).unwrap().1
    };
    let (ate_chained, ate_graph) = (ate(&chained.trace.estimate), ate(&graph.trace.estimate));
    let closures = graph.trace.loop_closures.as_deref().unwrap();
    let counts = loop_closure_metrics(closures);
    let wrong = counts.iter().find(|(k, _)| *k == "loop_closures_wrong").unwrap().1 as usize;
    eprintln!(
        "pose_graph: ATE {ate_graph:.3} m against PL-ICP chained {ate_chained:.3} m; {} closures, {wrong} wrong",
        closures.len()
    );
    // the consecutive edges are PL-ICP's own matches
    assert_eq!(graph.trace.matches.len(), chained.trace.matches.len());
    for (a, b) in graph.trace.matches.iter().zip(&chained.trace.matches) {
        assert_eq!((a.estimate, a.initial), (b.estimate, b.initial));
    }
    assert!(closures.len() >= 100, "{} closures", closures.len());
    assert!(wrong * 10 <= closures.len(), "{wrong} of {} closures wrong", closures.len());
    assert!(ate_graph < ate_chained, "pose graph {ate_graph} m against chained {ate_chained} m");
}
