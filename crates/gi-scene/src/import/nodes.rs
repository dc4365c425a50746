//! The node hierarchy and what nodes carry besides meshes: cameras and punctual lights.

use glam::{Mat4, Quat, Vec3};
use gltf::json;
use gltf::json::validation::Checked;

use super::{Result, Warnings, malformed, unusable};
use crate::{Camera, Light, LightKind, Node, Scene};

/// Deeper hierarchies are refused: nothing real nests this deep, and evaluating node
/// transforms walks parent chains.
const MAX_HIERARCHY_DEPTH: usize = 1000;

/// Root nodes of a file without scenes: every node that is no other node's child.
pub(super) fn parentless_nodes(root: &json::Root) -> Vec<usize> {
    let mut is_child = vec![false; root.nodes.len()];
    for child in root.nodes.iter().flat_map(|n| n.children.iter().flatten()) {
        if let Some(flag) = is_child.get_mut(child.value()) {
            *flag = true;
        }
    }
    (0..root.nodes.len()).filter(|&i| !is_child[i]).collect()
}

/// The nodes reachable from `roots`, depth first, as `(file index, parent file index)`.
/// The hierarchy must be a tree: a node reached twice (listed twice, two parents, or its own
/// ancestor) is an error.
pub(super) fn depth_first(
    root: &json::Root,
    roots: &[usize],
) -> Result<Vec<(usize, Option<usize>)>> {
    let mut visited = vec![false; root.nodes.len()];
    let mut order = Vec::new();
    // An explicit stack, so deep hierarchies cannot overflow the call stack.
    let mut stack: Vec<(usize, Option<usize>, usize)> =
        roots.iter().rev().map(|&r| (r, None, 0)).collect();
    while let Some((index, parent, depth)) = stack.pop() {
        let node = root
            .nodes
            .get(index)
            .ok_or_else(|| malformed(format!("node {index} does not exist")))?;
        if std::mem::replace(&mut visited[index], true) {
            return Err(malformed(format!(
                "nodes[{index}] is reached twice; the node hierarchy must be a tree"
            )));
        }
        if depth > MAX_HIERARCHY_DEPTH {
            return Err(unusable(format!(
                "the node hierarchy is deeper than {MAX_HIERARCHY_DEPTH} levels"
            )));
        }
        order.push((index, parent));
        for child in node.children.iter().flatten().rev() {
            stack.push((child.value(), Some(index), depth + 1));
        }
    }
    Ok(order)
}

/// A node's name, local transform (matrices are decomposed into TRS) and morph target
/// weights (checked against its mesh by the caller).
pub(super) fn import_node(json_node: &json::Node, index: usize) -> Result<Node> {
    let label = format!("nodes[{index}]");
    let (translation, rotation, scale) = match json_node.matrix {
        Some(m) => {
            if m.iter().any(|v| !v.is_finite()) {
                return Err(malformed(format!("{label}.matrix has non-finite values")));
            }
            let (scale, rotation, translation) =
                Mat4::from_cols_array(&m).to_scale_rotation_translation();
            if !(scale.is_finite() && translation.is_finite()) {
                return Err(malformed(format!("{label}.matrix cannot be decomposed")));
            }
            // A zero scale (used to hide nodes) leaves no rotation to recover.
            let rotation = if rotation.is_finite() {
                rotation.normalize()
            } else {
                Quat::IDENTITY
            };
            (translation, rotation, scale)
        }
        None => {
            let t = Vec3::from(json_node.translation.unwrap_or([0.0; 3]));
            let s = Vec3::from(json_node.scale.unwrap_or([1.0; 3]));
            let r = Quat::from_array(json_node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0));
            if !(t.is_finite() && s.is_finite() && r.is_finite()) {
                return Err(malformed(format!("{label} has a non-finite transform")));
            }
            if r.length_squared() < 1e-12 {
                return Err(malformed(format!("{label}.rotation is a zero quaternion")));
            }
            (t, r.normalize(), s)
        }
    };
    if let Some(weights) = &json_node.weights
        && weights.iter().any(|w| !w.is_finite())
    {
        return Err(malformed(format!("{label}.weights has non-finite values")));
    }
    Ok(Node {
        name: json_node.name.clone().unwrap_or_default(),
        translation,
        rotation,
        scale,
        weights: json_node.weights.clone(),
        ..Node::default()
    })
}

/// Imports perspective cameras; returns the model index of each file camera (`None` for the
/// orthographic ones, which are skipped).
pub(super) fn import_cameras(
    root: &json::Root,
    scene: &mut Scene,
    warnings: &mut Warnings,
) -> Result<Vec<Option<usize>>> {
    let mut map = Vec::with_capacity(root.cameras.len());
    for (index, camera) in root.cameras.iter().enumerate() {
        let label = format!("cameras[{index}]");
        match (&camera.type_, &camera.perspective) {
            (Checked::Valid(json::camera::Type::Perspective), Some(p)) => {
                let valid = p.yfov > 0.0
                    && p.yfov < std::f32::consts::PI
                    && p.znear.is_finite()
                    && p.znear > 0.0
                    && p.aspect_ratio.is_none_or(|a| a.is_finite() && a > 0.0);
                if !valid {
                    return Err(malformed(format!(
                        "{label}: invalid perspective parameters"
                    )));
                }
                scene.cameras.push(Camera {
                    name: camera
                        .name
                        .clone()
                        .unwrap_or_else(|| format!("camera {index}")),
                    yfov: p.yfov,
                    aspect_ratio: p.aspect_ratio,
                    znear: p.znear,
                });
                map.push(Some(scene.cameras.len() - 1));
            }
            (Checked::Valid(json::camera::Type::Orthographic), _) => {
                warnings.once("orthographic", || {
                    format!("{label}: orthographic cameras are not supported; skipped")
                });
                map.push(None);
            }
            _ => {
                return Err(malformed(format!(
                    "{label}: type and projection do not match"
                )));
            }
        }
    }
    Ok(map)
}

/// Imports KHR_lights_punctual lights; returns the model index of each file light.
pub(super) fn import_lights(
    root: &json::Root,
    scene: &mut Scene,
    warnings: &mut Warnings,
) -> Result<Vec<usize>> {
    use json::extensions::scene::khr_lights_punctual::Type;
    let lights = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map_or(&[][..], |l| &l.lights[..]);
    let mut map = Vec::with_capacity(lights.len());
    for (index, light) in lights.iter().enumerate() {
        let label = format!("KHR_lights_punctual.lights[{index}]");
        let color = Vec3::from(light.color);
        if !color.is_finite()
            || color.min_element() < 0.0
            || !light.intensity.is_finite()
            || light.intensity < 0.0
        {
            return Err(malformed(format!(
                "{label}: color and intensity must be finite and non-negative"
            )));
        }
        if light.range.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
            return Err(malformed(format!("{label}: range must be positive")));
        }
        let kind = match (&light.type_, &light.spot) {
            (Checked::Valid(Type::Directional), _) => LightKind::Directional,
            (Checked::Valid(Type::Point), _) => LightKind::Point,
            (Checked::Valid(Type::Spot), Some(spot)) => {
                let (inner, outer) = (spot.inner_cone_angle, spot.outer_cone_angle);
                if !(inner.is_finite()
                    && outer.is_finite()
                    && inner >= 0.0
                    && outer > 0.0
                    && outer <= std::f32::consts::FRAC_PI_2)
                {
                    return Err(malformed(format!(
                        "{label}: spot cone angles must satisfy 0 <= inner < outer <= pi/2"
                    )));
                }
                let mut inner_cone_angle = inner;
                if inner >= outer {
                    warnings.once("spot-cone", || {
                        format!(
                            "{label}: spot inner cone angle is not below the outer one; using a hard-edged cone"
                        )
                    });
                    inner_cone_angle = outer * 0.999;
                }
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle: outer,
                }
            }
            _ => return Err(malformed(format!("{label}: invalid light type"))),
        };
        scene.lights.push(Light {
            name: light
                .name
                .clone()
                .unwrap_or_else(|| format!("light {index}")),
            kind,
            color,
            intensity: light.intensity,
            range: light.range,
        });
        map.push(scene.lights.len() - 1);
    }
    Ok(map)
}
