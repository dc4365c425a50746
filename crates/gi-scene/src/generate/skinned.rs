//! `skinned-arm`: a two-bone arm on a floor, the smallest scene with a deforming skinned mesh.
//!
//! Not a bundled scene: it is test and tool content whose deformed vertices can be computed by
//! hand. The arm is an open square tube of half width [`ARM_HALF_WIDTH`] standing on the
//! origin along +Y, [`ARM_LENGTH`] tall, made of rings at y = 0, 1 and 2 with four flat sides
//! (each side has its own vertices, so normals are the sides' normals). Two joints skin it:
//! `shoulder` at the origin and its child `elbow` at y = 1. The bottom ring follows the
//! shoulder alone, the middle ring both with weight 0.5, the top ring the elbow alone. The
//! inverse bind matrices are the inverse of the joints' rest transforms (identity and a
//! translation by -1 in y), so at rest the mesh is where it was modelled. The elbow turns about
//! +Z from the rest pose to 90 degrees at t = 1 s and back at 2 s (linear keys, looping every
//! 2 s). The skinned node `arm` has a translation of its own, which glTF says to ignore.

use std::f32::consts::FRAC_PI_2;

use glam::{Mat4, Quat, Vec3, Vec4};

use crate::model::{
    Animation, Channel, ChannelValues, Interpolation, Material, Mesh, Node, Primitive, Scene, Skin,
    Sky,
};

/// Half width of the arm's square section, meters.
pub const ARM_HALF_WIDTH: f32 = 0.25;
/// Height of the arm at rest, meters; the elbow is at half of it.
pub const ARM_LENGTH: f32 = 2.0;
/// Translation of the skinned node, ignored by skinning.
pub const ARM_NODE_TRANSLATION: Vec3 = Vec3::new(5.0, 0.0, 0.0);
/// Time at which the elbow is bent by 90 degrees about +Z.
pub const ARM_BENT_TIME_S: f32 = 1.0;

/// Builds the `skinned-arm` scene: node 0 is the floor, 1 the shoulder, 2 the elbow, 3 the
/// skinned arm.
pub fn skinned_arm() -> Scene {
    let mut scene = Scene {
        name: "skinned-arm".into(),
        sky: Sky::Constant {
            radiance: Vec3::splat(1.0),
        },
        exposure: 1.0,
        frame_time_s: 1.0 / 30.0,
        ..Scene::default()
    };
    scene.add_diffuse_quad(
        Vec3::new(0.0, -0.01, 0.0),
        Vec3::X * 3.0,
        -Vec3::Z * 3.0,
        0.5,
    );
    scene.nodes[0].name = "floor".into();
    let shoulder = scene.nodes.len();
    scene.nodes.push(Node {
        name: "shoulder".into(),
        ..Node::default()
    });
    let elbow = scene.nodes.len();
    scene.nodes.push(Node {
        name: "elbow".into(),
        parent: Some(shoulder),
        translation: Vec3::Y * (ARM_LENGTH * 0.5),
        ..Node::default()
    });
    scene.materials.push(Material {
        name: "arm".into(),
        base_color: Vec4::new(0.8, 0.5, 0.2, 1.0),
        metallic: 0.0,
        roughness: 0.8,
        ..Material::default()
    });
    scene.meshes.push(Mesh {
        name: "arm".into(),
        weights: Vec::new(),
        primitives: vec![arm_primitive(scene.materials.len() - 1)],
    });
    scene.skins.push(Skin {
        name: "arm".into(),
        joints: vec![shoulder, elbow],
        inverse_bind_matrices: vec![
            Mat4::IDENTITY,
            Mat4::from_translation(-Vec3::Y * (ARM_LENGTH * 0.5)),
        ],
    });
    scene.nodes.push(Node {
        name: "arm".into(),
        translation: ARM_NODE_TRANSLATION,
        mesh: Some(scene.meshes.len() - 1),
        skin: Some(scene.skins.len() - 1),
        ..Node::default()
    });
    let bent = Quat::from_rotation_z(FRAC_PI_2);
    scene.animations.push(Animation {
        name: "bend".into(),
        channels: vec![Channel {
            node: elbow,
            times: vec![0.0, ARM_BENT_TIME_S, 2.0 * ARM_BENT_TIME_S],
            values: ChannelValues::Rotation(vec![Quat::IDENTITY, bent, Quat::IDENTITY]),
            interpolation: Interpolation::Linear,
        }],
    });
    scene
}

/// The tube: per side (facing +X, +Z, -X, -Z) two vertices per ring, rings at y = 0, 1, 2.
fn arm_primitive(material: usize) -> Primitive {
    let h = ARM_HALF_WIDTH;
    // Each side as (outward normal, first corner, second corner) in the XZ plane, counter-
    // clockwise seen from outside.
    let sides = [
        (Vec3::X, Vec3::new(h, 0.0, h), Vec3::new(h, 0.0, -h)),
        (Vec3::Z, Vec3::new(-h, 0.0, h), Vec3::new(h, 0.0, h)),
        (Vec3::NEG_X, Vec3::new(-h, 0.0, -h), Vec3::new(-h, 0.0, h)),
        (Vec3::NEG_Z, Vec3::new(h, 0.0, -h), Vec3::new(-h, 0.0, -h)),
    ];
    let ring_weights = [
        ([0, 1, 0, 0], Vec4::new(1.0, 0.0, 0.0, 0.0)),
        ([0, 1, 0, 0], Vec4::new(0.5, 0.5, 0.0, 0.0)),
        ([1, 0, 0, 0], Vec4::new(1.0, 0.0, 0.0, 0.0)),
    ];
    let mut primitive = Primitive {
        material,
        ..Primitive::default()
    };
    for (normal, a, b) in sides {
        let base = primitive.positions.len() as u32;
        for (ring, (joints, weights)) in ring_weights.iter().enumerate() {
            let y = Vec3::Y * (ARM_LENGTH * 0.5 * ring as f32);
            for corner in [a, b] {
                primitive.positions.push(corner + y);
                primitive.normals.push(normal);
                primitive.joints.push(*joints);
                primitive.weights.push(*weights);
            }
        }
        for ring in 0..2 {
            let (a0, b0) = (base + 2 * ring, base + 2 * ring + 1);
            let (a1, b1) = (a0 + 2, b0 + 2);
            primitive
                .indices
                .extend_from_slice(&[a0, b0, b1, a0, b1, a1]);
        }
    }
    primitive
}

/// The `skinned-arm` scene with a finer arm: a round tube of `rings` rings of `sides` vertices
/// (radius [`ARM_HALF_WIDTH`], [`ARM_LENGTH`] tall; 2 x `rings` x `sides` triangles, shared
/// vertices with radial normals), the elbow's weight rising linearly from 0 at y = 0.5 to 1 at
/// y = 1.5 (the shoulder's is the rest). For tests and benchmarks of deforming geometry at any
/// size; `rings` and `sides` are clamped to at least 1 and 3.
pub fn skinned_tube(rings: u32, sides: u32) -> Scene {
    let (rings, sides) = (rings.max(1), sides.max(3));
    let mut scene = skinned_arm();
    let material = scene.materials.len() - 1;
    let mut primitive = Primitive {
        material,
        ..Primitive::default()
    };
    for ring in 0..=rings {
        let y = ARM_LENGTH * ring as f32 / rings as f32;
        let elbow = (y - 0.25 * ARM_LENGTH).clamp(0.0, 0.5 * ARM_LENGTH) / (0.5 * ARM_LENGTH);
        for side in 0..sides {
            let angle = std::f32::consts::TAU * side as f32 / sides as f32;
            let normal = Vec3::new(angle.cos(), 0.0, -angle.sin());
            primitive
                .positions
                .push(normal * ARM_HALF_WIDTH + Vec3::Y * y);
            primitive.normals.push(normal);
            primitive.joints.push([0, 1, 0, 0]);
            primitive
                .weights
                .push(Vec4::new(1.0 - elbow, elbow, 0.0, 0.0));
        }
    }
    for ring in 0..rings {
        for side in 0..sides {
            let next = (side + 1) % sides;
            let (a0, b0) = (ring * sides + side, ring * sides + next);
            let (a1, b1) = (a0 + sides, b0 + sides);
            primitive
                .indices
                .extend_from_slice(&[a0, b0, b1, a0, b1, a1]);
        }
    }
    if let Some(mesh) = scene.meshes.last_mut() {
        mesh.primitives = vec![primitive];
    }
    scene.name = "skinned-tube".into();
    scene
}
