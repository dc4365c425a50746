// Pass `pc/shadow`, HSGI's "ReSTIR GI shadow" (GDC 2023, "PC / Console Solution"), one
// invocation per trace pixel: one visibility ray from the receiver to the sample the spatial
// reuse chose. Visible: kept. Occluded: the pixel falls back to its temporal reservoir (reused
// from its own rays, so with little visibility bias) and remembers the occluder's distance and
// the occluded direction for the multi-sample shading's neighbour test (`shade`).
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), bindings 1-7 the scene
// (`gi::scene`), then the buffers of `gi::pc::restir::rays`. Group 1: the BVH (`gi::bvh`).

#import gi::bvh::{Ray, trace_closest, BVH_MISS}
#import gi::packing::{pack_unit_vector, unpack_unit_vector}
#import gi::pc::restir::common::{
    uniforms, has_surface, load_reservoir, load_resolved, store_resolved, SAMPLE_SKY,
    SAMPLE_OCCLUDED, FLAG_SPATIAL, FLAG_SHADOW, FLAG_TEMPORAL, FAR
}
#import gi::pc::restir::rays::{load_surface, initial, temporal, resolved, SHADOW_MARGIN, offset_origin}

@compute @workgroup_size(8, 8)
fn shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.trace_px) {
        return;
    }
    let index = id.y * uniforms.trace_px.x + id.x;
    var r = load_reservoir(temporal[index]);
    if (uniforms.flags & FLAG_TEMPORAL) == 0u {
        r = load_reservoir(initial[index]);
    }
    let fallback = r;
    if (uniforms.flags & FLAG_SPATIAL) != 0u {
        r = load_resolved(resolved[index]);
    }
    let s = load_surface(index);
    if (uniforms.flags & FLAG_SHADOW) == 0u || !has_surface(s) || r.w <= 0.0 {
        resolved[index] = store_resolved(r);
        return;
    }
    let n = unpack_unit_vector(s.normal);
    let origin = offset_origin(s.position, n);
    var dir: vec3<f32>;
    var t_max = FAR;
    if (r.flags & SAMPLE_SKY) != 0u {
        dir = r.position;
    } else {
        let d = r.position - origin;
        let len = length(d);
        dir = d / max(len, 1e-12);
        t_max = len * (1.0 - SHADOW_MARGIN);
    }
    let hit = trace_closest(Ray(origin, 0.0, dir, t_max));
    if hit.triangle == BVH_MISS {
        resolved[index] = store_resolved(r);
        return;
    }
    var back = fallback;
    back.flags |= SAMPLE_OCCLUDED;
    back.occluder_distance = hit.t;
    back.occluder_direction = pack_unit_vector(dir);
    resolved[index] = store_resolved(back);
}
