//! The exact CPU voxelizer: the oracle of the GPU pass `cache/voxelize`
//! (`shaders/cache/voxelize.wgsl`), which applies the same rules in the same f32 arithmetic.
//!
//! Rules for a voxel of edge `s` centered at `c` and the triangles binned to its brick:
//!
//! - **Occupancy**: some triangle overlaps the voxel box (Akenine-Möller's separating axis
//!   test, "Fast 3D Triangle-Box Overlap Testing", 2001). The box is half-open along the world
//!   axes (`[c - s/2, c + s/2)`), so a triangle lying exactly in the plane between two voxels
//!   belongs to the upper one only and axis-aligned walls on the grid do not occupy two
//!   layers. Degenerate (zero-area) triangles occupy nothing.
//! - **Normal**: the sum of the overlapping triangles' area vectors *clipped to the voxel*
//!   (area-weighted geometric normals, weighted by the area inside the voxel), normalized. When
//!   the sum is less than [`NORMAL_CANCEL_FRACTION`] of the summed areas (facing surfaces
//!   cancel: the two faces of a wall thinner than a voxel, also where such a wall stands on a
//!   floor), the closest triangle's geometric normal.
//! - **Coverage** (albedo.a): the clipped area projected on the normal, over `s^2`, at most 1:
//!   the fraction of rays along the normal through the voxel that hit the surface.
//! - **Albedo**: the material of the triangle whose closest point is nearest to `c` (first in
//!   list order on ties), evaluated at that point: the Lambert lobe's albedo at the
//!   cosine-weighted mean view cosine 2/3 (`Brdf::diffuse_albedo`: base color, metallic,
//!   roughness and specular layer textured, as `gi::brdf`), standing for its mean over the
//!   directions a voxel reflects into.
//! - **Emission**: the emitted power of the voxel's triangles spread over the cross-section of
//!   its stored box along the normal ([`crate::layout::box_cross_section`]): the sum of each
//!   triangle's emission (the reference's `emission`, either side, at the triangle's point
//!   closest to `c`) times its clipped area projected on the normal, over that cross-section.
//!   A ray along the normal through the box then carries the emitter's mean radiance over the
//!   box's face. An emitter covering part of a voxel does not shine with its full radiance
//!   from the whole voxel: the cornell-box ceiling panel (0.18 m²) lit the mobile tier's
//!   probes as a 1 m² panel at the 0.5 m level under the earlier rule (the closest
//!   triangle's emission).
//! - **State**: [`STATE_DYNAMIC`] when an overlapping triangle belongs to a dynamic node; age 0;
//!   the box around the overlapping triangles clipped to the voxel
//!   ([`crate::layout::geometry_box_bits`]; the whole voxel when they only touch it).

use gi_reference::brdf::{Brdf, DielectricSpecular};
use gi_scene::{AlphaMode, Material, TextureRef, sample_texture};
use glam::{IVec3, Vec2, Vec3, Vec4};

use crate::binning::{CacheScene, TRIANGLE_DYNAMIC_BIT};
use crate::layout::{
    BRICK_VOXELS, STATE_DYNAMIC, VOXELS_PER_BRICK, VoxelSurface, box_cross_section,
    geometry_box_bits, mask_cell,
};
use crate::packing::{pack_rgb9e5, pack_unit_vector, pack4x8unorm};

/// Where the area-vector sum counts as cancelled: below this fraction of the summed areas.
///
/// Surfaces meeting at a right angle keep their mean normal (the sum is 0.71 of the areas at
/// an edge, 0.58 at a corner); surfaces facing each other do not. Where a 5 cm wall stands on
/// the floor (thin-wall), one voxel holds both faces of the wall and the floor: the faces
/// cancel and the floor's normal (0.33 of the areas) would remain, so that a ray from inside
/// the room, reading the side that faces it along that normal, saw the sunlit floor outside
/// (the cache's irradiance inside that room was twice the reference's without sky light).
/// The wall's closest face keeps the two sides of the wall apart. Below 1e-3 (its earlier
/// value) only a thin wall alone counted as cancelled.
pub const NORMAL_CANCEL_FRACTION: f32 = 0.5;

/// True when triangle `v` overlaps the box of half edge `half` centered at `center`
/// (half-open along the world axes, closed along the others; see the module docs).
pub fn triangle_box_overlap(v: [Vec3; 3], center: Vec3, half: f32) -> bool {
    let [v0, v1, v2] = v.map(|p| p - center);
    // World axes, half-open: the box is [-half, half).
    let lo = v0.min(v1).min(v2);
    let hi = v0.max(v1).max(v2);
    if lo.cmpge(Vec3::splat(half)).any() || hi.cmplt(Vec3::splat(-half)).any() {
        return false;
    }
    let edges = [v1 - v0, v2 - v1, v0 - v2];
    let normal = edges[0].cross(edges[1]);
    if normal == Vec3::ZERO {
        return false;
    }
    // The triangle's plane against the box.
    let d = normal.dot(v0);
    if d.abs() > half * normal.abs().element_sum() {
        return false;
    }
    // The nine cross products of box axes and triangle edges.
    for edge in edges {
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            let a = axis.cross(edge);
            let (p0, p1, p2) = (a.dot(v0), a.dot(v1), a.dot(v2));
            let r = half * a.abs().element_sum();
            if p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r {
                return false;
            }
        }
    }
    true
}

/// Area vector (area times unit geometric normal) of triangle `v` clipped to the box of half
/// edge `half` centered at `center` (Sutherland-Hodgman against the six faces).
pub fn clipped_area_vector(v: [Vec3; 3], center: Vec3, half: f32) -> Vec3 {
    clip_to_box(v, center, half).0
}

/// Triangle `v` clipped to the box of half edge `half` centered at `center`: its area vector
/// and the bounds `(lo, hi)` of the clipped polygon relative to `center` (`lo > hi` when
/// nothing of it is left).
pub fn clip_to_box(v: [Vec3; 3], center: Vec3, half: f32) -> (Vec3, Vec3, Vec3) {
    let empty = (Vec3::ZERO, Vec3::splat(half), Vec3::splat(-half));
    let mut polygon: Vec<Vec3> = v.iter().map(|p| *p - center).collect();
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            // Keep the side where sign * p[axis] <= half.
            let inside = |p: Vec3| sign * p[axis] <= half;
            let mut clipped = Vec::with_capacity(polygon.len() + 1);
            for i in 0..polygon.len() {
                let (a, b) = (polygon[i], polygon[(i + 1) % polygon.len()]);
                if inside(a) {
                    clipped.push(a);
                }
                if inside(a) != inside(b) {
                    let t = (half - sign * a[axis]) / (sign * (b[axis] - a[axis]));
                    clipped.push(a + (b - a) * t);
                }
            }
            polygon = clipped;
            if polygon.len() < 3 {
                return empty;
            }
        }
    }
    let mut sum = Vec3::ZERO;
    let (mut lo, mut hi) = (polygon[0], polygon[0]);
    for i in 1..polygon.len() {
        lo = lo.min(polygon[i]);
        hi = hi.max(polygon[i]);
        if i + 1 < polygon.len() {
            sum += (polygon[i] - polygon[0]).cross(polygon[i + 1] - polygon[0]);
        }
    }
    (sum * 0.5, lo, hi)
}

/// Barycentric weights `(w0, w1, w2)` of the point of triangle `v` closest to `p` (Ericson,
/// "Real-Time Collision Detection", 5.1.5).
pub fn closest_point_barycentrics(v: [Vec3; 3], p: Vec3) -> Vec3 {
    let [a, b, c] = v;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return Vec3::X;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return Vec3::Y;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return Vec3::new(1.0 - t, t, 0.0);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return Vec3::Z;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return Vec3::new(1.0 - t, 0.0, t);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return Vec3::new(0.0, 1.0 - t, t);
    }
    let denom = 1.0 / (va + vb + vc);
    let (w1, w2) = (vb * denom, vc * denom);
    Vec3::new(1.0 - w1 - w2, w1, w2)
}

/// One voxelized brick: its occupancy mask and the surface of each voxel (zero where empty).
#[derive(Clone, Debug, PartialEq)]
pub struct BrickVoxels {
    pub mask: u64,
    pub surfaces: [VoxelSurface; VOXELS_PER_BRICK as usize],
}

/// Voxelizes world brick `brick` of a level with voxels of `voxel_size_m`, from its binned
/// triangle references (see [`crate::binning`]).
pub fn voxelize_brick(
    scene: &CacheScene<'_>,
    voxel_size_m: f32,
    brick: IVec3,
    triangles: &[u32],
) -> BrickVoxels {
    let mut voxels = BrickVoxels {
        mask: 0,
        surfaces: [VoxelSurface::default(); VOXELS_PER_BRICK as usize],
    };
    let half = 0.5 * voxel_size_m;
    for bit in 0..VOXELS_PER_BRICK {
        let voxel = brick * BRICK_VOXELS as i32 + mask_cell(bit).as_ivec3();
        let center = (voxel.as_vec3() + 0.5) * voxel_size_m;
        if let Some(surface) = voxelize_voxel(scene, center, half, triangles) {
            voxels.mask |= 1u64 << bit;
            voxels.surfaces[bit as usize] = surface;
        }
    }
    voxels
}

/// The surface of the voxel centered at `center`, or `None` when no triangle overlaps it.
fn voxelize_voxel(
    scene: &CacheScene<'_>,
    center: Vec3,
    half: f32,
    triangles: &[u32],
) -> Option<VoxelSurface> {
    let mut area_sum = Vec3::ZERO;
    let mut area_total = 0.0f32;
    // Bounds of the clipped triangles (relative to `center`); empty while `lo > hi`.
    let mut box_lo = Vec3::splat(half);
    let mut box_hi = Vec3::splat(-half);
    let mut dynamic = false;
    // (squared distance, triangle index, barycentrics) of the closest overlapping triangle.
    let mut closest: Option<(f32, u32, Vec3)> = None;
    let mut overlapping = Vec::new();
    for &reference in triangles {
        let index = reference & !TRIANGLE_DYNAMIC_BIT;
        let v = scene.vertices(index);
        if !triangle_box_overlap(v, center, half) {
            continue;
        }
        dynamic |= reference & TRIANGLE_DYNAMIC_BIT != 0;
        let (area, lo, hi) = clip_to_box(v, center, half);
        box_lo = box_lo.min(lo);
        box_hi = box_hi.max(hi);
        area_sum += area;
        area_total += area.length();
        let b = closest_point_barycentrics(v, center);
        overlapping.push((index, area, b));
        let point = v[0] * b.x + v[1] * b.y + v[2] * b.z;
        let distance_sq = (point - center).length_squared();
        if closest.is_none_or(|(d, _, _)| distance_sq < d) {
            closest = Some((distance_sq, index, b));
        }
    }
    let (_, triangle, b) = closest?;
    let sum_length = area_sum.length();
    let normal = if area_total > 0.0 && sum_length > NORMAL_CANCEL_FRACTION * area_total {
        area_sum / sum_length
    } else {
        let [a, b, c] = scene.vertices(triangle);
        (b - a).cross(c - a).normalize_or(Vec3::Y)
    };
    let mut projected = 0.0f32;
    let mut emitted = Vec3::ZERO;
    for &(index, area, b) in &overlapping {
        // Alpha-tested surfaces cover the voxel where they exist (at the point closest to its
        // center).
        let area = area.dot(normal).abs() * coverage_at(scene, index, b);
        projected += area;
        let (_, emission) = material_at(scene, index, b);
        if emission != Vec3::ZERO {
            emitted += emission * area;
        }
    }
    let coverage = (projected / (4.0 * half * half)).min(1.0);
    let (albedo, _) = material_at(scene, triangle, b);
    let box_bits = if box_lo.cmple(box_hi).all() {
        geometry_box_bits(box_lo, box_hi, half)
    } else {
        0
    };
    Some(VoxelSurface {
        albedo: pack4x8unorm(albedo.extend(coverage)),
        normal: pack_unit_vector(normal),
        emission: pack_rgb9e5(emitted / box_cross_section(box_bits, normal, 2.0 * half)),
        state: if dynamic { STATE_DYNAMIC } else { 0 } | box_bits,
    })
}

/// The cosine-weighted mean of `n.v` over the hemisphere: where the cache, which reflects
/// diffusely into every direction, evaluates the Lambert lobe's albedo (`cache/voxelize`).
pub const MEAN_VIEW_COSINE: f32 = 2.0 / 3.0;

/// How much of the surface of frame triangle `triangle` exists at barycentrics `b`: 1 for
/// opaque materials, 1 or 0 by the cutoff for alpha `MASK`, the alpha for `BLEND`
/// (`gi::scene::surface_coverage` on the GPU).
pub fn coverage_at(scene: &CacheScene<'_>, triangle: u32, b: Vec3) -> f32 {
    let attributes = &scene.frame.attributes[triangle as usize];
    let Some(material) = scene.scene.materials.get(attributes.material as usize) else {
        return 1.0;
    };
    if material.alpha_mode == AlphaMode::Opaque {
        return 1.0;
    }
    let interpolate = |[t0, t1, t2]: [Vec2; 3]| t0 * b.x + t1 * b.y + t2 * b.z;
    let (uv0, uv1) = (interpolate(attributes.uvs), interpolate(attributes.uvs1));
    let alpha = material.base_color.w
        * sample_texture(&scene.scene.textures, material.base_color_texture, uv0, uv1).w;
    match material.alpha_mode {
        AlphaMode::Mask { cutoff } if alpha >= cutoff => 1.0,
        AlphaMode::Mask { .. } => 0.0,
        _ => alpha.clamp(0.0, 1.0),
    }
}

/// Diffuse albedo and emission of frame triangle `triangle` at barycentrics `b`, with the
/// reference's material and texture rules.
pub fn material_at(scene: &CacheScene<'_>, triangle: u32, b: Vec3) -> (Vec3, Vec3) {
    let attributes = &scene.frame.attributes[triangle as usize];
    let interpolate = |[t0, t1, t2]: [Vec2; 3]| t0 * b.x + t1 * b.y + t2 * b.z;
    let (uv0, uv1) = (interpolate(attributes.uvs), interpolate(attributes.uvs1));
    let default = Material::default();
    let material = scene
        .scene
        .materials
        .get(attributes.material as usize)
        .unwrap_or(&default);
    let sample = |texture: Option<TextureRef>| -> Vec4 {
        sample_texture(&scene.scene.textures, texture, uv0, uv1)
    };
    let base = material.base_color.truncate() * sample(material.base_color_texture).truncate();
    let mr = sample(material.metallic_roughness_texture);
    let layer = DielectricSpecular::of_material(material, sample);
    let albedo = Brdf::new(base, material.metallic * mr.z, material.roughness * mr.y)
        .with_specular(layer)
        .diffuse_albedo(MEAN_VIEW_COSINE);
    let emission = if material.emissive == Vec3::ZERO {
        Vec3::ZERO
    } else {
        material.emissive * sample(material.emissive_texture).truncate()
    };
    (albedo, emission)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::geometry_box;

    #[test]
    fn overlap_is_half_open_along_the_world_axes() {
        // A quad half in the plane y = 0: it belongs to the box above, not the one below.
        let tri = [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        assert!(triangle_box_overlap(tri, Vec3::new(0.0, 0.5, 0.0), 0.5));
        assert!(!triangle_box_overlap(tri, Vec3::new(0.0, -0.5, 0.0), 0.5));
        // A triangle crossing a box corner diagonally without touching it.
        let far = [
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
        ];
        assert!(!triangle_box_overlap(far, Vec3::splat(-0.1), 0.5));
        assert!(triangle_box_overlap(far, Vec3::splat(0.6), 0.5));
        let area = clipped_area_vector(tri, Vec3::new(0.0, 0.5, 0.0), 0.5);
        // The square minus two corners of 1/16 each cut off by the slanted edges.
        assert!(
            (area - Vec3::new(0.0, -0.875, 0.0)).length() < 1e-5,
            "{area}"
        );
        let (_, lo, hi) = clip_to_box(tri, Vec3::new(0.0, 0.5, 0.0), 0.5);
        assert_eq!(
            (lo, hi),
            (Vec3::new(-0.5, -0.5, -0.5), Vec3::new(0.5, -0.5, 0.5))
        );
        let b = closest_point_barycentrics(tri, Vec3::new(0.0, 3.0, -5.0));
        assert!((b - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6, "{b}");
    }

    /// A door's jamb (the plane x = 0.3 of a unit voxel, facing +x into the opening) fills
    /// the voxel's occupancy but only the slab next to it in the box: rays through the rest of
    /// the voxel pass.
    #[test]
    fn the_geometry_box_holds_the_clipped_triangles_and_little_more() {
        let jamb = [
            Vec3::new(0.3, -2.0, -2.0),
            Vec3::new(0.3, 2.0, -2.0),
            Vec3::new(0.3, 0.0, 3.0),
        ];
        let (center, half) = (Vec3::splat(0.5), 0.5);
        assert!(triangle_box_overlap(jamb, center, half));
        let (_, lo, hi) = clip_to_box(jamb, center, half);
        let (box_lo, box_hi) = geometry_box(geometry_box_bits(lo, hi, half));
        // x in eighths: 0.3 lies in [2/8, 3/8]; y and z span the voxel.
        assert_eq!(box_lo, glam::UVec3::new(2, 0, 0));
        assert_eq!(box_hi, glam::UVec3::new(3, 8, 8));
        // A plane on an eighth is rounded outwards to a slab an eighth thick.
        let on_step = jamb.map(|p| Vec3::new(0.25, p.y, p.z));
        let (_, lo, hi) = clip_to_box(on_step, center, half);
        let (box_lo, box_hi) = geometry_box(geometry_box_bits(lo, hi, half));
        assert!(box_lo.x <= 2 && box_hi.x >= 2 && box_hi.x - box_lo.x <= 2);
        // Zero bits are the whole voxel.
        assert_eq!(geometry_box(0), (glam::UVec3::ZERO, glam::UVec3::splat(8)));
    }
}
