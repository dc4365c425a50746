// Linear blend skinning of glTF skins on the GPU (`gi_gpu::skin`): the vertices of skinned
// meshes whose joints move, placed by their joints each frame and written straight into the
// scene's shading buffers (`gi::scene`), so their triangles need no upload.
//
// The same arithmetic as the CPU evaluation (`gi_scene`'s `skin` module): a vertex's matrix is
// `sum_i w_i * joint_matrix[j_i]` divided by the sum of the weights (left as blended when the
// sum is 1), or the node's own world transform when no weight is usable; normals go through
// the cofactor matrix times the sign of the determinant, tangents through the matrix, both
// renormalized; a triangle whose first vertex's matrix mirrors swaps its second and third
// vertices. Weights that cannot be used (negative, non-finite, a joint outside the skin or
// not a node) were set to zero when the vertices were uploaded.
//
// `skin_vertices` runs one invocation per vertex, `skin_triangles` one per triangle, in one
// compute pass (its dispatches' writes are ordered before the next dispatch's reads).

#import gi::math::FLT_MAX
#import gi::scene::{TriangleShading, TriangleExtras, normalize_or}

// A vertex at rest (morphed at the node's constant weights) in its mesh's space.
struct SkinVertex {
    // w: the index (bits) of the matrix placing the vertex when no weight is usable.
    position: vec4<f32>,
    // w: 1 when the vertex has a tangent.
    normal: vec4<f32>,
    // xyz, bitangent sign in w.
    tangent: vec4<f32>,
    weights: vec4<f32>,
    // Indices into `matrices`.
    joints: vec4<u32>,
}

// A vertex in world space.
struct SkinnedVertex {
    // w: 1 when the vertex's matrix mirrors.
    position: vec4<f32>,
    normal: vec4<f32>,
    tangent: vec4<f32>,
}

// A triangle of a skinned mesh, with what does not change from frame to frame.
struct SkinTriangle {
    // xyz: indices into the vertices; w: the frame triangle index it is written at.
    vertices: vec4<u32>,
    // TEXCOORD_0 of vertices a and b, then of c with TEXCOORD_1 of a, then TEXCOORD_1 of b, c.
    uv_ab: vec4<f32>,
    uv_c_uv1_a: vec4<f32>,
    uv1_bc: vec4<f32>,
    // x: material, y: node.
    material_node: vec4<u32>,
}

struct Counts {
    vertices: u32,
    triangles: u32,
    // 1 when `scene_extras` holds every triangle (tangents and TEXCOORD_1).
    has_extras: u32,
    // Invocations per row of the dispatch grid (its x size times the workgroup size).
    row: u32,
}

@group(0) @binding(0) var<uniform> counts: Counts;
@group(0) @binding(1) var<storage, read> vertices: array<SkinVertex>;
@group(0) @binding(2) var<storage, read> matrices: array<mat4x4<f32>>;
@group(0) @binding(3) var<storage, read_write> skinned: array<SkinnedVertex>;
@group(0) @binding(4) var<storage, read> triangles: array<SkinTriangle>;
@group(0) @binding(5) var<storage, read_write> scene_triangles: array<TriangleShading>;
@group(0) @binding(6) var<storage, read_write> scene_extras: array<TriangleExtras>;

const WORKGROUP_SIZE: u32 = 64u;

fn blended_matrix(vertex: SkinVertex) -> mat4x4<f32> {
    var m = mat4x4<f32>(vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
    var total = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let w = vertex.weights[k];
        if w > 0.0 {
            m = m + matrices[vertex.joints[k]] * w;
            total += w;
        }
    }
    if !(total > 0.0 && total <= FLT_MAX) {
        return matrices[bitcast<u32>(vertex.position.w)];
    }
    if total == 1.0 {
        return m;
    }
    return m * (1.0 / total);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn skin_vertices(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x + id.y * counts.row;
    if index >= counts.vertices {
        return;
    }
    let vertex = vertices[index];
    let m = blended_matrix(vertex);
    let c0 = m[0].xyz;
    let c1 = m[1].xyz;
    let c2 = m[2].xyz;
    let mirrors = dot(c0, cross(c1, c2)) < 0.0;
    let side = select(1.0, -1.0, mirrors);
    let cofactor = mat3x3<f32>(cross(c1, c2), cross(c2, c0), cross(c0, c1)) * side;
    var out: SkinnedVertex;
    out.position = vec4((m * vec4(vertex.position.xyz, 1.0)).xyz, select(0.0, 1.0, mirrors));
    out.normal = vec4(normalize_or(cofactor * vertex.normal.xyz, vec3(0.0, 1.0, 0.0)), 0.0);
    out.tangent = vec4(0.0);
    if vertex.normal.w > 0.5 {
        let t = vertex.tangent;
        let sign = select(1.0, -1.0, t.w < 0.0) * side;
        out.tangent = vec4(normalize_or((m * vec4(t.xyz, 0.0)).xyz, vec3(0.0)), sign);
    }
    skinned[index] = out;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn skin_triangles(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x + id.y * counts.row;
    if index >= counts.triangles {
        return;
    }
    let triangle = triangles[index];
    var a = skinned[triangle.vertices.x];
    var b = skinned[triangle.vertices.y];
    var c = skinned[triangle.vertices.z];
    var uv_a = triangle.uv_ab.xy;
    var uv_b = triangle.uv_ab.zw;
    var uv_c = triangle.uv_c_uv1_a.xy;
    var uv1_a = triangle.uv_c_uv1_a.zw;
    var uv1_b = triangle.uv1_bc.xy;
    var uv1_c = triangle.uv1_bc.zw;
    // A mirroring matrix flips the winding: the CPU swaps the second and third vertices.
    if a.position.w > 0.5 {
        let vertex = b;
        b = c;
        c = vertex;
        let uv = uv_b;
        uv_b = uv_c;
        uv_c = uv;
        let uv1 = uv1_b;
        uv1_b = uv1_c;
        uv1_c = uv1;
    }
    var shading: TriangleShading;
    shading.pa = vec4(a.position.xyz, f32(triangle.material_node.y));
    shading.pb = vec4(b.position.xyz, 0.0);
    shading.pc = vec4(c.position.xyz, 0.0);
    shading.na = vec4(a.normal.xyz, uv_a.x);
    shading.nb = vec4(b.normal.xyz, uv_b.x);
    shading.nc = vec4(c.normal.xyz, uv_c.x);
    shading.v = vec3(uv_a.y, uv_b.y, uv_c.y);
    shading.material = triangle.material_node.x;
    let frame_index = triangle.vertices.w;
    scene_triangles[frame_index] = shading;
    if counts.has_extras != 0u {
        var extras: TriangleExtras;
        extras.ta = a.tangent;
        extras.tb = b.tangent;
        extras.tc = c.tangent;
        extras.uv_ab = vec4(uv1_a, uv1_b);
        extras.uv_c = uv1_c;
        extras.pad_a = vec2(0.0);
        scene_extras[frame_index] = extras;
    }
}
