// Test kernels of the BRDF and sampling parity tests: they run `gi::brdf` and `gi::sampling`
// on batches of inputs made on the CPU, so the test can compare every result with the CPU
// reference's implementation of the same functions.
//
// - `brdf_parity`: one `BrdfCase` in, one `BrdfResult` out: BRDF construction, eval, pdf,
//   lobe probability, a sample and the split-sum specular albedo, plus the warps, the power
//   heuristic and the frame.
// - `sampler_parity`: per (seed low, seed high, pixel, sample) the first SEQUENCE_LENGTH
//   numbers of `sampler_next_f32`.
// - `pcg32_parity`: per (state low, high, stream low, high) the first SEQUENCE_LENGTH raw
//   outputs of `pcg32_new` + `sampler_next_u32`.

#import gi::brdf::{
    brdf_new, brdf_with_specular, dielectric_specular_new, brdf_eval, brdf_pdf, brdf_sample,
    brdf_specular_probability, brdf_f0, brdf_f90, brdf_diffuse_albedo, specular_albedo
}
#import gi::math::luminance
#import gi::sampling::{
    Sampler, cosine_hemisphere, uniform_triangle, power_heuristic, frame_from_normal,
    frame_to_local, frame_to_world, sampler_new, pcg32_new, sampler_next_u32, sampler_next_f32
}

// How many numbers of each random sequence are written.
const SEQUENCE_LENGTH: u32 = 32u;

// Inputs of one BRDF case. 96 bytes; mirrored by `BrdfCase` in the test, which checks this
// layout with naga.
struct BrdfCase {
    base: vec3<f32>,
    metallic: f32,
    wo: vec3<f32>,
    roughness: f32,
    wi: vec3<f32>,
    u_lobe: f32,
    // Unit normal of the frame checks.
    normal: vec3<f32>,
    // First pdf of the power heuristic.
    pdf_a: f32,
    u: vec2<f32>,
    // Second pdf of the power heuristic.
    pdf_b: f32,
    // The dielectric layer: `dielectric_specular_new(specular_weight, specular_color, ior)`.
    ior: f32,
    specular_color: vec3<f32>,
    specular_weight: f32,
}

// Outputs of one BRDF case. 176 bytes; mirrored by `BrdfResult` in the test.
struct BrdfResult {
    f: vec3<f32>,
    pdf: f32,
    f0: vec3<f32>,
    specular_probability: f32,
    diffuse_albedo: vec3<f32>,
    alpha: f32,
    sample_wi: vec3<f32>,
    sample_pdf: f32,
    sample_f: vec3<f32>,
    // 1 when the sample is valid, else 0.
    sample_valid: u32,
    cosine_wi: vec3<f32>,
    // `power_heuristic(pdf_a, pdf_b)`.
    heuristic_weight: f32,
    frame_x: vec3<f32>,
    // Barycentrics of `uniform_triangle(u)`.
    triangle_b1: f32,
    frame_y: vec3<f32>,
    triangle_b2: f32,
    // `wo` taken to the frame of `normal`.
    local: vec3<f32>,
    // Luminance of `base`.
    base_luminance: f32,
    // `wo` read as frame coordinates, taken to world space.
    world: vec3<f32>,
    // Green channel of `specular_albedo(f0, f90, roughness, wo.z)`.
    split_sum_albedo: f32,
    // The dielectric layer's F0 and the whole layer's F90.
    dielectric_reflectance: vec3<f32>,
    grazing_reflectance: f32,
}

@group(0) @binding(0) var<storage, read> cases: array<BrdfCase>;
@group(0) @binding(1) var<storage, read_write> results: array<BrdfResult>;

@compute @workgroup_size(64)
fn brdf_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&cases) {
        return;
    }
    let c = cases[i];
    let layer = dielectric_specular_new(c.specular_weight, c.specular_color, c.ior);
    let brdf = brdf_with_specular(brdf_new(c.base, c.metallic, c.roughness), layer);
    let bs = brdf_sample(brdf, c.wo, c.u_lobe, c.u);
    let frame = frame_from_normal(c.normal);
    let barycentrics = uniform_triangle(c.u);
    results[i] = BrdfResult(
        brdf_eval(brdf, c.wo, c.wi),
        brdf_pdf(brdf, c.wo, c.wi),
        brdf_f0(brdf),
        brdf_specular_probability(brdf, c.wo),
        brdf_diffuse_albedo(brdf, c.wo.z),
        brdf.alpha,
        bs.wi,
        bs.pdf,
        bs.f,
        select(0u, 1u, bs.valid),
        cosine_hemisphere(c.u),
        power_heuristic(c.pdf_a, c.pdf_b),
        frame.x,
        barycentrics.x,
        frame.y,
        barycentrics.y,
        frame_to_local(frame, c.wo),
        luminance(c.base),
        frame_to_world(frame, c.wo),
        specular_albedo(brdf_f0(brdf), brdf_f90(brdf), c.roughness, c.wo.z).y,
        layer.reflectance,
        brdf_f90(brdf),
    );
}

@group(0) @binding(0) var<storage, read> sequence_inputs: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> sequence_outputs: array<u32>;

@compute @workgroup_size(64)
fn sampler_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&sequence_inputs) {
        return;
    }
    let input = sequence_inputs[i];
    var sampler = sampler_new(input.xy, input.z, input.w);
    for (var k = 0u; k < SEQUENCE_LENGTH; k++) {
        sequence_outputs[i * SEQUENCE_LENGTH + k] = bitcast<u32>(sampler_next_f32(&sampler));
    }
}

@compute @workgroup_size(64)
fn pcg32_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&sequence_inputs) {
        return;
    }
    let input = sequence_inputs[i];
    var sampler: Sampler = pcg32_new(input.xy, input.zw);
    for (var k = 0u; k < SEQUENCE_LENGTH; k++) {
        sequence_outputs[i * SEQUENCE_LENGTH + k] = sampler_next_u32(&sampler);
    }
}
