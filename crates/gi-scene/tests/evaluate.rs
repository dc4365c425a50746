//! `Scene::evaluate_into`: a frame moved to a later time in place equals a fresh evaluation
//! bit for bit, while it evaluates again only what changed.

use gi_scene::generate::skinned_tube;
use gi_scene::{
    Animation, Channel, ChannelValues, Evaluation, Interpolation, MorphTarget, Scene, SceneFrame,
};
use glam::Vec3;

/// Bit-for-bit equality of everything a frame holds (`Debug` prints every float exactly).
fn assert_same_frame(a: &SceneFrame, b: &SceneFrame, label: &str) {
    assert_eq!(a.time_s, b.time_s, "{label}");
    assert_eq!(a.camera, b.camera, "{label}");
    assert_eq!(a.lights, b.lights, "{label}");
    assert_eq!(a.world_from_node, b.world_from_node, "{label}");
    assert_eq!(a.morph_weights, b.morph_weights, "{label}");
    assert_eq!(a.positions_only, b.positions_only, "{label}");
    assert_eq!(a.triangles.len(), b.triangles.len(), "{label}");
    for t in 0..a.triangles.len() {
        assert_eq!(
            format!("{:?} {:?}", a.triangles[t], a.attributes[t]),
            format!("{:?} {:?}", b.triangles[t], b.attributes[t]),
            "{label}: triangle {t}"
        );
    }
}

/// The skinned tube with a morph target whose weight an animation drives, beside the static
/// floor: skinned, morphed and static geometry in one scene.
fn tube_with_animated_weights() -> Scene {
    let mut scene = skinned_tube(4, 5);
    let arm = scene.nodes.iter().position(|n| n.name == "arm").unwrap();
    let mesh = scene.nodes[arm].mesh.unwrap();
    let tube = &mut scene.meshes[mesh].primitives[0];
    tube.targets.push(MorphTarget {
        positions: vec![Vec3::new(0.05, 0.0, 0.0); tube.positions.len()],
        ..MorphTarget::default()
    });
    scene.animations.push(Animation {
        name: "breathe".into(),
        channels: vec![Channel {
            node: arm,
            times: vec![0.0, 0.7, 1.4],
            values: ChannelValues::Weights(vec![vec![0.0], vec![1.0], vec![0.0]]),
            interpolation: Interpolation::Linear,
        }],
    });
    scene
}

#[test]
fn frames_moved_in_place_equal_fresh_evaluations() {
    let dynamic = gi_scene::load("dynamic").unwrap();
    let tube = skinned_tube(6, 7);
    let morphed = tube_with_animated_weights();
    for (label, scene) in [
        ("dynamic", dynamic),
        ("skinned-tube", tube),
        ("morphed-tube", morphed),
    ] {
        assert!(scene.is_animated(), "{label}");
        let arm = scene.nodes.iter().position(|n| n.name == "arm");
        let mut only = Evaluation::default();
        if let Some(arm) = arm {
            only.positions_only = vec![false; scene.nodes.len()];
            only.positions_only[arm] = true;
        }
        for evaluation in [Evaluation::default(), only] {
            let mut frame = scene.evaluate_with(0.0, None, &evaluation);
            for time in [0.2, 0.9, 1.6, 3.1] {
                let evaluated = scene.evaluate_into(&mut frame, time, None, &evaluation);
                let fresh = scene.evaluate_with(time, None, &evaluation);
                assert_same_frame(&frame, &fresh, &format!("{label} at {time} s"));
                assert_ne!(frame.geometry_revision, 0, "{label}");
                // Only the animated nodes' triangles were evaluated again (the floor, and
                // `dynamic`'s static room, were kept).
                let total = frame.triangles.len();
                assert!(
                    evaluated > 0 && evaluated < total,
                    "{label}: {evaluated} of {total}"
                );
                // The same time again changes no triangle: nothing is evaluated and the
                // revision stays.
                let revision = frame.geometry_revision;
                assert_eq!(scene.evaluate_into(&mut frame, time, None, &evaluation), 0);
                assert_eq!(
                    frame.geometry_revision, revision,
                    "{label} at {time} s again"
                );
            }
        }
    }
}

/// A frame of another scene, or evaluated with another `Evaluation`, is replaced whole.
#[test]
fn frames_of_another_scene_are_evaluated_whole() {
    let tube = skinned_tube(3, 4);
    let other = skinned_tube(5, 4);
    let mut frame = other.evaluate(0.3, None);
    tube.evaluate_into(&mut frame, 0.5, None, &Evaluation::default());
    assert_same_frame(&frame, &tube.evaluate(0.5, None), "another scene");
    let arm = tube.nodes.iter().position(|n| n.name == "arm").unwrap();
    let mut only = vec![false; tube.nodes.len()];
    only[arm] = true;
    let evaluation = Evaluation {
        positions_only: only,
    };
    tube.evaluate_into(&mut frame, 0.5, None, &evaluation);
    assert_same_frame(
        &frame,
        &tube.evaluate_with(0.5, None, &evaluation),
        "another evaluation",
    );
}

/// In a scene where only a light moves, no triangle changes: the frame keeps its geometry
/// revision (state derived from the triangles, such as the radiance cache's index, is kept),
/// and a camera move alone keeps it too.
#[test]
fn frames_without_moving_geometry_keep_their_revision() {
    let mut scene = skinned_tube(3, 4);
    // The elbow's animation now moves nothing: its keys all hold the rest rotation.
    for channel in scene.animations.iter_mut().flat_map(|a| &mut a.channels) {
        if let ChannelValues::Rotation(keys) = &mut channel.values {
            keys.iter_mut().for_each(|k| *k = glam::Quat::IDENTITY);
        }
    }
    let mut frame = scene.evaluate(0.0, None);
    let revision = frame.geometry_revision;
    let camera = gi_scene::CameraView::look_at(Vec3::new(3.0, 2.0, 5.0), Vec3::ZERO, 0.8);
    for time in [0.1, 0.5, 1.0] {
        let evaluated = scene.evaluate_into(&mut frame, time, Some(camera), &Evaluation::default());
        assert_eq!(evaluated, 0, "{time} s");
        assert_eq!(frame.geometry_revision, revision, "{time} s");
        assert_same_frame(&frame, &scene.evaluate(time, Some(camera)), "still");
    }
}
