//! Tangents for normal mapping: repairing the file's `TANGENT` values and generating
//! MikkTSpace tangents (the convention normal maps are baked in, per the glTF specification)
//! where the file has none.

use std::collections::HashMap;

use bevy_mikktspace::{Geometry, TangentSpace, generate_tangents};
use glam::{Vec2, Vec3, Vec4};

use crate::Primitive;

/// A stand-in tangent for vertex normal `normal`: some unit vector orthogonal to it, with a
/// positive bitangent sign.
fn fallback(normal: Vec3) -> Vec4 {
    normal.any_orthonormal_vector().extend(1.0)
}

/// Makes file tangents usable: unit xyz and a w of exactly +1 or -1. A tangent with a zero,
/// NaN or infinite direction becomes [`fallback`]. Returns how many were replaced.
pub(super) fn repair(tangents: &mut [Vec4], normals: &[Vec3]) -> usize {
    let mut replaced = 0;
    for (tangent, &normal) in tangents.iter_mut().zip(normals) {
        let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
        *tangent = match tangent.truncate().try_normalize() {
            Some(direction) => direction.extend(sign),
            None => {
                replaced += 1;
                fallback(normal)
            }
        };
    }
    replaced
}

/// Fills `primitive.tangents` with MikkTSpace tangents computed from its positions, normals
/// and texture coordinates `uvs` (one per vertex: the set the normal texture reads, with its
/// transform applied). A vertex whose corners get different tangents (a UV seam or mirrored
/// UVs) is split into one vertex per tangent, so `positions`, `normals`, `uvs`, `uvs1`,
/// `joints`, `weights`, the morph targets' displacements and `indices` may grow. Fails only when the split vertices would
/// overflow 32-bit indices.
pub(super) fn generate(primitive: &mut Primitive, uvs: &[Vec2]) -> Result<(), String> {
    let vertex_count = primitive.positions.len();
    let mut geometry = Mikk {
        positions: &primitive.positions,
        normals: &primitive.normals,
        uvs,
        indices: &primitive.indices,
        corners: vec![None; primitive.indices.len()],
    };
    // The crate's error type has no variants: generation cannot fail.
    let _ = generate_tangents(&mut geometry);
    let corners = geometry.corners;

    let mut tangents: Vec<Vec4> = primitive.normals.iter().map(|&n| fallback(n)).collect();
    let mut assigned: Vec<Option<[u32; 4]>> = vec![None; vertex_count];
    let mut splits: HashMap<(usize, [u32; 4]), u32> = HashMap::new();
    for (corner, index) in primitive.indices.iter_mut().enumerate() {
        let vertex = *index as usize;
        let normal = primitive.normals[vertex];
        let tangent = corners[corner]
            .map(|t| Vec4::from(t.tangent_encoded()))
            .filter(|t| t.is_finite() && t.truncate().length_squared() > 0.5)
            .unwrap_or_else(|| fallback(normal));
        let bits = tangent.to_array().map(f32::to_bits);
        match assigned[vertex] {
            None => {
                assigned[vertex] = Some(bits);
                tangents[vertex] = tangent;
            }
            Some(existing) if existing == bits => {}
            Some(_) => {
                let copy = match splits.get(&(vertex, bits)) {
                    Some(&copy) => copy,
                    None => {
                        let copy = u32::try_from(primitive.positions.len())
                            .map_err(|_| "too many vertices after splitting tangent seams")?;
                        primitive.positions.push(primitive.positions[vertex]);
                        primitive.normals.push(normal);
                        if let Some(&uv) = primitive.uvs.get(vertex) {
                            primitive.uvs.push(uv);
                        }
                        if let Some(&uv) = primitive.uvs1.get(vertex) {
                            primitive.uvs1.push(uv);
                        }
                        if let Some(&joints) = primitive.joints.get(vertex) {
                            primitive.joints.push(joints);
                        }
                        if let Some(&weights) = primitive.weights.get(vertex) {
                            primitive.weights.push(weights);
                        }
                        for target in &mut primitive.targets {
                            for deltas in [
                                &mut target.positions,
                                &mut target.normals,
                                &mut target.tangents,
                            ] {
                                if let Some(&delta) = deltas.get(vertex) {
                                    deltas.push(delta);
                                }
                            }
                        }
                        tangents.push(tangent);
                        splits.insert((vertex, bits), copy);
                        copy
                    }
                };
                *index = copy;
            }
        }
    }
    primitive.tangents = tangents;
    Ok(())
}

/// The triangle list as MikkTSpace reads it, and the tangent it gives each corner.
struct Mikk<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    uvs: &'a [Vec2],
    indices: &'a [u32],
    corners: Vec<Option<TangentSpace>>,
}

impl Mikk<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.indices[face * 3 + vert] as usize
    }
}

impl Geometry for Mikk<'_> {
    fn num_faces(&self) -> usize {
        self.indices.len() / 3
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.vertex(face, vert)].to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.vertex(face, vert)].to_array()
    }

    fn set_tangent(&mut self, tangent_space: Option<TangentSpace>, face: usize, vert: usize) {
        if let Some(corner) = self.corners.get_mut(face * 3 + vert) {
            *corner = tangent_space;
        }
    }
}
