// Pass `pc/spatial`, ReSTIR GI's spatial reuse (Ouyang et al. 2021, with HSGI's changes,
// GDC 2023, "PC / Console Solution"), per trace pixel, from the temporal reservoirs or without
// temporal reuse the initial ones: `spatial_samples` neighbours within `spatial_radius` trace
// pixels, kept when they lie on the same surface (heuristic selection by normal and plane
// distance), combined with the Jacobian and no visibility (the biased reuse; the shadow pass
// restores visibility).
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), then the buffers of
// `gi::pc::restir::bindings`.

#import gi::sampling::{sampler_new, sampler_next_f32, sampler_next_2d, concentric_disk}
#import gi::packing::unpack_unit_vector
#import gi::pc::restir::bindings::{load_surface, initial, temporal_out, resolved, trace_index}
#import gi::pc::restir::common::{
    uniforms, Reservoir, empty_reservoir, has_surface, target_pdf, reconnection_jacobian,
    combiner_new, combiner_add, combiner_finish, similar_surfaces, load_reservoir, store_resolved,
    FLAG_TEMPORAL
}

// The reservoir the spatial reuse starts from at trace pixel `i`.
fn reuse_source(i: u32) -> Reservoir {
    if (uniforms.flags & FLAG_TEMPORAL) != 0u {
        return load_reservoir(temporal_out[i]);
    }
    return load_reservoir(initial[i]);
}

@compute @workgroup_size(8, 8)
fn spatial(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.trace_px) {
        return;
    }
    let index = trace_index(id.xy);
    let s = load_surface(index);
    if !has_surface(s) {
        resolved[index] = store_resolved(empty_reservoir());
        return;
    }
    let n = unpack_unit_vector(s.normal);
    var sampler = sampler_new(uniforms.seed ^ vec2(0x7f4a7c15u, 0u), index, uniforms.frame_index);
    var c = combiner_new();
    let own = reuse_source(index);
    combiner_add(&c, own, own.m, target_pdf(own, s.position, n), 1.0, sampler_next_f32(&sampler));
    for (var k = 0u; k < uniforms.spatial_samples; k++) {
        let offset = concentric_disk(sampler_next_2d(&sampler)) * uniforms.spatial_radius;
        let u_select = sampler_next_f32(&sampler);
        let q = vec2<i32>(id.xy) + vec2<i32>(round(offset));
        if any(q < vec2(0)) || any(q >= vec2<i32>(uniforms.trace_px)) || all(q == vec2<i32>(id.xy)) {
            continue;
        }
        let qi = trace_index(vec2<u32>(q));
        let sq = load_surface(qi);
        if !similar_surfaces(s, sq, uniforms.normal_cos, uniforms.plane_tolerance) {
            continue;
        }
        let rq = reuse_source(qi);
        let j = reconnection_jacobian(rq, sq.position, s.position, uniforms.jacobian_max);
        combiner_add(&c, rq, rq.m, target_pdf(rq, s.position, n), j, u_select);
    }
    resolved[index] = store_resolved(combiner_finish(c));
}
