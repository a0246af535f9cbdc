//! Tests of the laser pose graph: the relative-pose factor, the overlap test, and loop closing
//! on a simulated loop.

use super::*;
use crate::geom::Point2;

#[test]
fn inlier_fraction_is_one_at_the_true_pose_and_falls_off_it() {
    // a wall along x = 3 seen from the origin, beams every 1°
    let beams: Vec<Option<Point2>> = (-40..=40)
        .map(|d| {
            let b = f64::from(d).to_radians();
            Some(Point2::new(3.0, 3.0 * b.tan()))
        })
        .collect();
    assert_eq!(inlier_fraction(&beams, &beams, &Pose2::IDENTITY, 0.05), 1.0);
    // 0.1 m towards the wall: every return 0.1 m off the surface
    assert_eq!(inlier_fraction(&beams, &beams, &Pose2::new(0.1, 0.0, 0.0), 0.05), 0.0);
    // sliding along the wall keeps returns on it, except those past its ends
    let slid = inlier_fraction(&beams, &beams, &Pose2::new(0.0, 0.5, 0.0), 0.05);
    assert!(slid > 0.8 && slid < 1.0, "{slid}");
    // no return: nothing overlaps
    assert_eq!(inlier_fraction(&beams, &[None, None], &Pose2::IDENTITY, 0.05), 0.0);
}

#[test]
fn a_depth_jump_is_not_a_surface() {
    // two returns 2 m apart: the segment between them is not a wall
    let reference = vec![Some(Point2::new(2.0, -1.0)), Some(Point2::new(2.0, 1.0))];
    let middle = vec![Some(Point2::new(2.0, 0.0))];
    assert_eq!(inlier_fraction(&reference, &middle, &Pose2::IDENTITY, 0.05), 0.0);
    let close = vec![Some(Point2::new(2.0, -0.2)), Some(Point2::new(2.0, 0.2))];
    assert_eq!(inlier_fraction(&close, &middle, &Pose2::IDENTITY, 0.05), 1.0);
}

#[test]
fn candidates_are_the_nearest_far_enough_back_and_facing_alike() {
    let params = PoseGraphParams {
        loop_min_separation: 3,
        loop_candidates: 2,
        ..PoseGraphParams::default()
    };
    let poses = vec![
        Pose2::new(0.0, 0.0, 0.0),  // 0: 1 m away
        Pose2::new(1.0, 0.0, 3.0),  // 1: facing away
        Pose2::new(0.5, 0.0, 0.0),  // 2: 0.5 m away
        Pose2::new(10.0, 0.0, 0.0), // 3: too far
        Pose2::new(1.0, 0.1, 0.0),  // 4: too recent
        Pose2::new(1.0, 0.0, 0.0),  // 5: recent
        Pose2::new(1.0, 0.0, 0.2),  // 6: the new node
    ];
    assert_eq!(candidates(&poses, 6, &params), vec![2, 0]);
    assert!(candidates(&poses, 2, &params).is_empty());
}

#[test]
fn every_front_end_is_valid_and_others_are_refused() {
    for name in front_ends() {
        let p = PoseGraphParams { front_end: name.into(), ..PoseGraphParams::default() };
        assert_eq!(p.validate(), vec![], "{name}");
    }
    let p = PoseGraphParams { front_end: "pose_graph".into(), ..PoseGraphParams::default() };
    let v = p.validate();
    assert_eq!(v.len(), 1);
    assert_eq!(v[0].key, "front_end");
    assert!(v[0].message.contains("pl_icp"), "{}", v[0].message);
}
