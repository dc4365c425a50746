//! Geometry helpers shared by the scene generators.
//!
//! Every shape is built around its own origin and placed with [`MeshData::add`], which applies an
//! affine transform (normals go through the inverse transpose, mirrored transforms keep the
//! winding outward). Triangles wind counter-clockwise seen from the side their normals point to,
//! and closed shapes (boxes, prisms, spheres, cylinders, cones) have outward normals. Boxes,
//! prisms and quads carry texture coordinates in meters so that a tiling texture keeps its scale
//! on every face; spheres use the usual longitude/latitude mapping in `[0, 1]`.

use std::collections::BTreeMap;

use glam::{Affine3A, Vec2, Vec3};

use crate::model::Primitive;

/// Triangles under construction: one future [`Primitive`].
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
}

impl MeshData {
    /// Appends `shape` transformed by `transform`.
    pub fn add(&mut self, shape: &MeshData, transform: Affine3A) {
        let base = self.positions.len() as u32;
        let normal_matrix = transform.matrix3.inverse().transpose();
        self.positions.extend(
            shape
                .positions
                .iter()
                .map(|p| transform.transform_point3(*p)),
        );
        self.normals.extend(
            shape
                .normals
                .iter()
                .map(|n| (normal_matrix * *n).normalize_or(Vec3::Y)),
        );
        self.uvs.extend_from_slice(&shape.uvs);
        let mirrored = transform.matrix3.determinant() < 0.0;
        for tri in shape.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0] + base, tri[1] + base, tri[2] + base];
            if mirrored {
                self.indices.extend_from_slice(&[a, c, b]);
            } else {
                self.indices.extend_from_slice(&[a, b, c]);
            }
        }
    }

    /// Appends `shape` as it is.
    pub fn append(&mut self, shape: &MeshData) {
        self.add(shape, Affine3A::IDENTITY);
    }

    /// Appends `shape` moved by `offset`.
    pub fn add_at(&mut self, shape: &MeshData, offset: Vec3) {
        self.add(shape, Affine3A::from_translation(offset));
    }

    /// The finished primitive with material `material`.
    pub fn into_primitive(self, material: usize) -> Primitive {
        Primitive {
            positions: self.positions,
            normals: self.normals,
            uvs: self.uvs,
            indices: self.indices,
            material,
            ..Default::default()
        }
    }

    fn vertex(&mut self, position: Vec3, normal: Vec3, uv: Vec2) -> u32 {
        self.positions.push(position);
        self.normals.push(normal);
        self.uvs.push(uv);
        self.positions.len() as u32 - 1
    }

    fn triangle(&mut self, a: u32, b: u32, c: u32) {
        self.indices.extend_from_slice(&[a, b, c]);
    }

    /// Replaces the normals by area-weighted averages of the adjacent face normals, joining
    /// vertices that share a position (for shapes deformed after construction).
    pub fn smooth_normals(&mut self) {
        // Adding zero turns -0.0 into 0.0, so equal positions get equal keys.
        let key = |p: Vec3| (p + 0.0).to_array().map(f32::to_bits);
        let mut sums: BTreeMap<[u32; 3], Vec3> = BTreeMap::new();
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| self.positions[tri[k] as usize]);
            // Unnormalized: its length is twice the triangle's area.
            let face = (b - a).cross(c - a);
            for &i in tri {
                *sums.entry(key(self.positions[i as usize])).or_default() += face;
            }
        }
        for (normal, position) in self.normals.iter_mut().zip(&self.positions) {
            *normal = sums[&key(*position)].normalize_or(Vec3::Y);
        }
    }
}

/// A flat parallelogram spanned from `corner` by `edge_u` and `edge_v`, facing
/// `edge_u x edge_v`.
pub fn quad(corner: Vec3, edge_u: Vec3, edge_v: Vec3) -> MeshData {
    let mut mesh = MeshData::default();
    add_quad(&mut mesh, corner, edge_u, edge_v);
    mesh
}

fn add_quad(mesh: &mut MeshData, corner: Vec3, edge_u: Vec3, edge_v: Vec3) {
    let normal = edge_u.cross(edge_v).normalize();
    let (lu, lv) = (edge_u.length(), edge_v.length());
    // glTF texture space has v pointing down: the far edge along `edge_v` is v = 0.
    let a = mesh.vertex(corner, normal, Vec2::new(0.0, lv));
    let b = mesh.vertex(corner + edge_u, normal, Vec2::new(lu, lv));
    let c = mesh.vertex(corner + edge_u + edge_v, normal, Vec2::new(lu, 0.0));
    let d = mesh.vertex(corner + edge_v, normal, Vec2::new(0.0, 0.0));
    mesh.triangle(a, b, c);
    mesh.triangle(a, c, d);
}

/// An axis-aligned box centered on the origin with flat per-face normals (24 vertices, 12
/// triangles).
pub fn cuboid(half: Vec3) -> MeshData {
    let (x, y, z) = (half.x, half.y, half.z);
    let mut mesh = MeshData::default();
    let faces = [
        (
            Vec3::new(x, -y, z),
            Vec3::new(0.0, 0.0, -2.0 * z),
            Vec3::Y * 2.0 * y,
        ),
        (
            Vec3::new(-x, -y, -z),
            Vec3::new(0.0, 0.0, 2.0 * z),
            Vec3::Y * 2.0 * y,
        ),
        (
            Vec3::new(-x, y, z),
            Vec3::X * 2.0 * x,
            Vec3::new(0.0, 0.0, -2.0 * z),
        ),
        (Vec3::new(-x, -y, -z), Vec3::X * 2.0 * x, Vec3::Z * 2.0 * z),
        (Vec3::new(-x, -y, z), Vec3::X * 2.0 * x, Vec3::Y * 2.0 * y),
        (
            Vec3::new(x, -y, -z),
            Vec3::NEG_X * 2.0 * x,
            Vec3::Y * 2.0 * y,
        ),
    ];
    for (corner, u, v) in faces {
        add_quad(&mut mesh, corner, u, v);
    }
    mesh
}

/// The box spanning `min..max` (world-aligned walls, slabs and blocks).
pub fn box_between(min: Vec3, max: Vec3) -> MeshData {
    let mut mesh = MeshData::default();
    mesh.add_at(&cuboid((max - min) * 0.5), (min + max) * 0.5);
    mesh
}

/// A vertical prism over a convex footprint given as (x, z) points in either winding, from
/// height `y0` to `y1`, with flat normals.
pub fn prism(footprint: &[Vec2], y0: f32, y1: f32) -> MeshData {
    let mut points = footprint.to_vec();
    // The top face's fan must wind counter-clockwise seen from +Y.
    let winding: f32 = (0..points.len())
        .map(|i| {
            let (p, q) = (points[i], points[(i + 1) % points.len()]);
            p.y * q.x - p.x * q.y
        })
        .sum();
    if winding < 0.0 {
        points.reverse();
    }
    let at = |p: Vec2, y: f32| Vec3::new(p.x, y, p.y);
    let mut mesh = MeshData::default();
    for i in 0..points.len() {
        let (p, q) = (points[i], points[(i + 1) % points.len()]);
        add_quad(
            &mut mesh,
            at(p, y0),
            at(q, y0) - at(p, y0),
            Vec3::Y * (y1 - y0),
        );
    }
    for (y, normal) in [(y1, Vec3::Y), (y0, Vec3::NEG_Y)] {
        let first = mesh.positions.len() as u32;
        for p in &points {
            mesh.vertex(at(*p, y), normal, *p);
        }
        for i in 1..points.len() as u32 - 1 {
            if normal.y > 0.0 {
                mesh.triangle(first, first + i, first + i + 1);
            } else {
                mesh.triangle(first, first + i + 1, first + i);
            }
        }
    }
    mesh
}

/// Point on the unit circle at angle `theta`, counter-clockwise seen from +Y.
fn ring(theta: f32) -> Vec3 {
    Vec3::new(theta.cos(), 0.0, -theta.sin())
}

/// Angle of step `i` of `segments` around a circle; callers wrap `i` so that the last step
/// lands exactly on the first point.
fn angle(i: u32, segments: u32) -> f32 {
    i as f32 / segments as f32 * std::f32::consts::TAU
}

/// A UV sphere centered on the origin with smooth normals.
pub fn uv_sphere(radius: f32, segments: u32, rings: u32) -> MeshData {
    let mut mesh = MeshData::default();
    for j in 0..=rings {
        let v = j as f32 / rings as f32;
        let phi = v * std::f32::consts::PI;
        for i in 0..=segments {
            let u = i as f32 / segments as f32;
            // Exact poles and a seam that repeats the first column bit for bit keep the
            // surface closed.
            let normal = match j {
                0 => Vec3::Y,
                _ if j == rings => Vec3::NEG_Y,
                _ => ring(angle(i % segments, segments)) * phi.sin() + Vec3::Y * phi.cos(),
            };
            mesh.vertex(normal * radius, normal, Vec2::new(u, v));
        }
    }
    let row = segments + 1;
    for j in 0..rings {
        for i in 0..segments {
            let (a, b) = (j * row + i, (j + 1) * row + i);
            let (c, d) = (b + 1, a + 1);
            // The rows at the poles collapse to a point: keep only the triangle with area.
            if j + 1 < rings || rings == 1 {
                mesh.triangle(a, b, c);
            }
            if j > 0 {
                mesh.triangle(a, c, d);
            }
        }
    }
    mesh
}

/// An icosphere (subdivided icosahedron) centered on the origin with smooth normals.
pub fn icosphere(radius: f32, subdivisions: u32) -> MeshData {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut points: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: BTreeMap<(u32, u32), u32> = BTreeMap::new();
        let mut midpoint = |a: u32, b: u32, points: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                points.push((points[a as usize] + points[b as usize]).normalize());
                points.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let ab = midpoint(a, b, &mut points);
            let bc = midpoint(b, c, &mut points);
            let ca = midpoint(c, a, &mut points);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let mut mesh = MeshData::default();
    for p in &points {
        // Longitude/latitude mapping; the seam is not split (the shapes are not textured).
        let u = 0.5 + p.z.atan2(p.x) / std::f32::consts::TAU;
        let v = p.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
        mesh.vertex(*p * radius, *p, Vec2::new(u, v));
    }
    for [a, b, c] in faces {
        mesh.triangle(a, b, c);
    }
    mesh
}

/// A capped cylinder standing on the origin, from y = 0 to `height`: smooth sides, flat caps.
pub fn cylinder(radius: f32, height: f32, segments: u32) -> MeshData {
    let mut mesh = MeshData::default();
    for i in 0..segments {
        let (n0, n1) = (
            ring(angle(i, segments)),
            ring(angle((i + 1) % segments, segments)),
        );
        let (u0, u1) = (i as f32 / segments as f32, (i + 1) as f32 / segments as f32);
        let a = mesh.vertex(n0 * radius, n0, Vec2::new(u0, 1.0));
        let b = mesh.vertex(n1 * radius, n1, Vec2::new(u1, 1.0));
        let c = mesh.vertex(n1 * radius + Vec3::Y * height, n1, Vec2::new(u1, 0.0));
        let d = mesh.vertex(n0 * radius + Vec3::Y * height, n0, Vec2::new(u0, 0.0));
        mesh.triangle(a, b, c);
        mesh.triangle(a, c, d);
    }
    add_cap(&mut mesh, radius, height, segments, Vec3::Y);
    add_cap(&mut mesh, radius, 0.0, segments, Vec3::NEG_Y);
    mesh
}

/// A capped cone standing on the origin with its apex at y = `height`.
pub fn cone(radius: f32, height: f32, segments: u32) -> MeshData {
    let mut mesh = MeshData::default();
    // Slope normal: the side's outward direction tilted up by the cone's half-angle.
    let normal = |theta: f32| (ring(theta) * height + Vec3::Y * radius).normalize();
    for i in 0..segments {
        let (t0, t1) = (angle(i, segments), angle((i + 1) % segments, segments));
        // The apex has no single normal: each side triangle gets its own, mid-way round.
        let tm = (i as f32 + 0.5) / segments as f32 * std::f32::consts::TAU;
        let a = mesh.vertex(ring(t0) * radius, normal(t0), Vec2::new(0.0, 1.0));
        let b = mesh.vertex(ring(t1) * radius, normal(t1), Vec2::new(1.0, 1.0));
        let apex = mesh.vertex(Vec3::Y * height, normal(tm), Vec2::new(0.5, 0.0));
        mesh.triangle(a, b, apex);
    }
    add_cap(&mut mesh, radius, 0.0, segments, Vec3::NEG_Y);
    mesh
}

/// A flat disc of `segments` sides at height `y`, facing `normal` (+Y or -Y).
fn add_cap(mesh: &mut MeshData, radius: f32, y: f32, segments: u32, normal: Vec3) {
    let center = mesh.vertex(Vec3::Y * y, normal, Vec2::splat(0.5));
    let first = mesh.positions.len() as u32;
    for i in 0..segments {
        let p = ring(angle(i, segments));
        mesh.vertex(
            p * radius + Vec3::Y * y,
            normal,
            Vec2::new(p.x, p.z) * 0.5 + 0.5,
        );
    }
    for i in 0..segments {
        let (a, b) = (first + i, first + (i + 1) % segments);
        if normal.y > 0.0 {
            mesh.triangle(center, a, b);
        } else {
            mesh.triangle(center, b, a);
        }
    }
}

/// A terrain patch: a grid of `cells` quads covering `size` meters from `origin` (x, z), with
/// heights from `height(x, z)` evaluated at the same coordinates; normals come from central
/// differences of `height`, so patches built from one function join without seams.
pub fn heightfield(
    origin: Vec2,
    size: Vec2,
    cells: u32,
    height: impl Fn(f32, f32) -> f32,
) -> MeshData {
    let mut mesh = MeshData::default();
    let step = size / cells as f32;
    let eps = step.min_element() * 0.5;
    for j in 0..=cells {
        for i in 0..=cells {
            let xz = origin + Vec2::new(i as f32, j as f32) * step;
            let (x, z) = (xz.x, xz.y);
            let dx = (height(x + eps, z) - height(x - eps, z)) / (2.0 * eps);
            let dz = (height(x, z + eps) - height(x, z - eps)) / (2.0 * eps);
            let normal = Vec3::new(-dx, 1.0, -dz).normalize();
            mesh.vertex(Vec3::new(x, height(x, z), z), normal, xz);
        }
    }
    let row = cells + 1;
    for j in 0..cells {
        for i in 0..cells {
            let a = j * row + i;
            let (b, c, d) = (a + 1, a + row + 1, a + row);
            mesh.triangle(a, c, b);
            mesh.triangle(a, d, c);
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    /// Every edge (by position) is shared by exactly two triangles, once in each direction, and
    /// the enclosed volume is positive: the shape is closed and its triangles face outwards.
    fn assert_closed(mesh: &MeshData) {
        // Adding zero turns -0.0 into 0.0, so equal positions get equal keys.
        let key = |i: u32| {
            (mesh.positions[i as usize] + 0.0)
                .to_array()
                .map(f32::to_bits)
        };
        let mut edges: BTreeMap<([u32; 3], [u32; 3]), i32> = BTreeMap::new();
        let mut volume = 0.0;
        for tri in mesh.indices.chunks_exact(3) {
            for k in 0..3 {
                let (a, b) = (key(tri[k]), key(tri[(k + 1) % 3]));
                if a < b {
                    *edges.entry((a, b)).or_default() += 1;
                } else {
                    *edges.entry((b, a)).or_default() -= 1;
                }
            }
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[tri[k] as usize]);
            volume += a.dot(b.cross(c)) / 6.0;
        }
        assert!(
            edges.values().all(|&n| n == 0),
            "open or inconsistent edges"
        );
        assert!(volume > 0.0, "inward facing");
    }

    /// Shading normals are unit length and on the side the winding faces.
    fn assert_normals_agree(mesh: &MeshData) {
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[tri[k] as usize]);
            let face = (b - a).cross(c - a);
            assert!(face.length() > 1e-9, "degenerate triangle");
            for &i in tri {
                let n = mesh.normals[i as usize];
                assert!((n.length() - 1.0).abs() < 1e-4);
                assert!(n.dot(face) > 0.0, "normal against winding");
            }
        }
    }

    #[test]
    fn closed_shapes_face_outwards() {
        let shapes = [
            cuboid(Vec3::new(1.0, 2.0, 0.5)),
            prism(
                &[Vec2::ZERO, Vec2::X, Vec2::new(1.0, 1.0), Vec2::Y],
                0.0,
                2.0,
            ),
            prism(
                &[Vec2::ZERO, Vec2::Y, Vec2::new(1.0, 1.0), Vec2::X],
                -1.0,
                0.0,
            ),
            uv_sphere(1.0, 12, 6),
            icosphere(1.0, 2),
            cylinder(0.5, 2.0, 10),
            cone(1.0, 2.0, 8),
        ];
        for shape in &shapes {
            assert_closed(shape);
            assert_normals_agree(shape);
        }
    }

    #[test]
    fn transforms_keep_shapes_outward() {
        let mut mesh = MeshData::default();
        let rotated = Affine3A::from_rotation_translation(Quat::from_rotation_y(0.3), Vec3::X);
        mesh.add(&cuboid(Vec3::ONE), rotated);
        let mirrored = Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0));
        mesh.add(&cylinder(1.0, 1.0, 6), mirrored);
        assert_normals_agree(&mesh);
    }

    #[test]
    fn heightfield_faces_up() {
        let mesh = heightfield(Vec2::splat(-2.0), Vec2::splat(4.0), 8, |x, z| {
            (x * 0.7).sin() + z * 0.2
        });
        assert_eq!(mesh.indices.len(), 128 * 3);
        assert_normals_agree(&mesh);
        assert!(mesh.normals.iter().all(|n| n.y > 0.0));
    }
}
