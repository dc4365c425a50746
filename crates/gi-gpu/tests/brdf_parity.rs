//! Parity of the shared WGSL BRDF and sampling code (`gi::brdf`, `gi::sampling`) with the CPU
//! reference, on the adapter in use (lavapipe in CI): the GPU path tier must implement the
//! reference's light transport exactly, so these functions must compute the same numbers.
//! Without an adapter the GPU tests skip loudly, or fail when `GI_REQUIRE_GPU` is set.
//!
//! # What is compared, and how closely
//!
//! - **Random numbers** must be bit-identical: the GPU sampler seeded with (seed, pixel,
//!   sample) against the reference's, and raw PCG32 against `rand_pcg::Pcg32`. Integer
//!   arithmetic has no rounding.
//! - **BRDF values and pdfs** (`eval`, `pdf`, and a sample's `f` and `pdf`):
//!   `|gpu - cpu| <= 1e-4 max(1, |cpu|) + condition`. The GPU evaluates the same formulas in
//!   the same order, so the two differ only by rounding where a compiler fuses a multiply-add
//!   or a device rounds a square root or division differently: at most a few ulps per
//!   operation over a few dozen operations, below `1e-5` relative for a well-conditioned
//!   value, so `1e-4` leaves a tenfold margin. Some values are ill-conditioned: a mirror's
//!   `D` at its peak, or a direction at the horizon where `z <= 0` switches the BRDF off. A
//!   few ulps of rounding in an intermediate act like a few ulps of change in the inputs, so
//!   the `condition` term is how far the CPU's own result moves when `wo` and `wi` move by
//!   [`DIRECTION_PERTURBATION`] (backward error analysis, measured rather than derived). The
//!   tests count the cases where that term dominates and assert they are a minority.
//! - **Sampled directions** (`sample`, `cosine_hemisphere`): `|gpu - cpu| <= 1e-5 +
//!   condition`, the condition measured by moving `u` by [`SAMPLE_PERTURBATION`], which
//!   covers the device's `sin`/`cos` error; `1e-5` is about 80 ulps of a unit component. The
//!   sample's `f` and `pdf` are compared with the CPU's `eval` and `pdf` at the GPU's
//!   direction, so a near-mirror's sharp lobe does not turn a tiny direction error into a
//!   large pdf difference. The choice of lobe and the validity of a sample must agree except
//!   where they are within rounding of their thresholds: `u_lobe` within `1e-5` of the
//!   specular probability, or a sample whose validity (`wi.z > 0`) flips when `u` moves by
//!   [`SAMPLE_PERTURBATION`]. Such cases are counted; those with `u` inside the square (not
//!   on its boundary, which the warps map to the horizon) must be at most 1% of all cases.
//! - **Everything else** (construction, `f0`, `f90`, luminance, lobe probability, triangle
//!   warp, power heuristic, frames): a few operations each, compared at `1e-6` absolute on
//!   values of order 1 (about 8 ulps). The specular layer's albedo and the diffuse albedo it
//!   weighs are long Chebyshev series: compared at [`SERIES_TOLERANCE`].

use bytemuck::{Pod, Zeroable};
use gi_gpu::{GpuContext, ShaderLibrary, rust_field_offsets, wgsl_struct_layout};
use gi_reference::brdf::{Brdf, DielectricSpecular, luminance, specular_albedo};
use glam::{Vec2, Vec3};
use rand::{Rng, RngExt, SeedableRng};
use rand_pcg::Pcg32;

use gi_reference::sampling::{
    Frame, Sampler, cosine_hemisphere, power_heuristic, uniform_triangle,
};

const SHADER: &str = "test/brdf_parity.wgsl";
const WORKGROUP_SIZE: usize = 64;
/// Numbers of each random sequence the kernels write (`SEQUENCE_LENGTH` in the shader).
const SEQUENCE_LENGTH: usize = 32;
/// Random BRDF cases; odd, so the last workgroup is partial.
const CASE_COUNT: usize = 4001;

/// Relative tolerance of BRDF values and pdfs, on `max(1, |cpu|)` (see the crate docs).
const VALUE_TOLERANCE: f32 = 1e-4;
/// Absolute tolerance of sampled direction components (see the crate docs).
const DIRECTION_TOLERANCE: f32 = 1e-5;
/// Absolute tolerance of short computations on values of order 1.
const SHORT_TOLERANCE: f32 = 1e-6;
/// Absolute tolerance of the specular layer's albedo and of what it weighs (the diffuse
/// albedo): two Chebyshev series of up to 136 terms whose coefficients sum to about 20 in
/// magnitude. Summed in the same order they round alike (lavapipe's are bit-identical); a
/// device that fuses multiply-adds rounds each term differently, about
/// `sqrt(136) * 20 * 2^-24` (1.4e-5) for independent roundings.
const SERIES_TOLERANCE: f32 = 2e-5;
/// How far direction components move to measure a value's condition: 2^-22, about four ulps
/// of a unit vector's largest component.
const DIRECTION_PERTURBATION: f32 = 1.0 / 4_194_304.0;
/// How far random numbers move to measure a sampled direction's condition: 2^-21, four ulps
/// of `2 pi u` near `2 pi`, so it also covers a `sin`/`cos` off by a few ulps.
const SAMPLE_PERTURBATION: f32 = 1.0 / 2_097_152.0;

/// Inputs of one case; mirrors `BrdfCase` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct BrdfCase {
    base: [f32; 3],
    metallic: f32,
    wo: [f32; 3],
    roughness: f32,
    wi: [f32; 3],
    u_lobe: f32,
    normal: [f32; 3],
    pdf_a: f32,
    u: [f32; 2],
    pdf_b: f32,
    ior: f32,
    specular_color: [f32; 3],
    specular_weight: f32,
}

/// Outputs of one case; mirrors `BrdfResult` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct BrdfResult {
    f: [f32; 3],
    pdf: f32,
    f0: [f32; 3],
    specular_probability: f32,
    diffuse_albedo: [f32; 3],
    alpha: f32,
    sample_wi: [f32; 3],
    sample_pdf: f32,
    sample_f: [f32; 3],
    sample_valid: u32,
    cosine_wi: [f32; 3],
    heuristic_weight: f32,
    frame_x: [f32; 3],
    triangle_b1: f32,
    frame_y: [f32; 3],
    triangle_b2: f32,
    local: [f32; 3],
    base_luminance: f32,
    world: [f32; 3],
    split_sum_albedo: f32,
    dielectric_reflectance: [f32; 3],
    grazing_reflectance: f32,
}

impl BrdfCase {
    fn brdf(&self) -> Brdf {
        Brdf::new(self.base.into(), self.metallic, self.roughness).with_specular(
            DielectricSpecular::new(self.specular_weight, self.specular_color.into(), self.ior),
        )
    }
}

/// A uniformly distributed unit vector.
fn unit_vector(rng: &mut Pcg32) -> Vec3 {
    let z = 1.0 - 2.0 * rng.random::<f32>();
    let phi = std::f32::consts::TAU * rng.random::<f32>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A direction for `wo` or `wi`: mostly above the surface, with grazing, normal and
/// below-the-surface directions over-represented because that is where f32 code breaks.
fn direction(rng: &mut Pcg32) -> Vec3 {
    let v = unit_vector(rng);
    match rng.random_range(0..10) {
        0 | 1 => {
            // Grazing: z between 1e-5 and 1e-2, log-uniform.
            let z = 10f32.powf(rng.random_range(-5.0..-2.0));
            let xy = Vec2::new(v.x, v.y).normalize_or(Vec2::X) * (1.0 - z * z).sqrt();
            Vec3::new(xy.x, xy.y, z)
        }
        2 => Vec3::Z,
        3 => -v.abs(),
        _ => Vec3::new(v.x, v.y, v.z.abs()),
    }
}

/// `wi` for a case: an independent direction, or the mirror direction of `wo` slightly
/// perturbed, where smooth lobes peak and are hardest to evaluate.
fn incident_direction(rng: &mut Pcg32, wo: Vec3) -> Vec3 {
    if rng.random_bool(0.3) {
        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        let spread = [0.0, 1e-3, 1e-2, 1e-1][rng.random_range(0..4)];
        (mirror + spread * unit_vector(rng)).normalize()
    } else {
        direction(rng)
    }
}

/// A pdf for the power heuristic: log-uniform over 12 decades, or 0 or infinity.
fn heuristic_pdf(rng: &mut Pcg32) -> f32 {
    match rng.random_range(0..20) {
        0 => 0.0,
        1 => f32::INFINITY,
        _ => 10f32.powf(rng.random_range(-6.0..6.0)),
    }
}

/// Random numbers for a warp, with the corners and centre of the square mixed in.
fn warp_input(rng: &mut Pcg32) -> Vec2 {
    const ALMOST_ONE: f32 = 1.0 - 1.0 / 16_777_216.0;
    match rng.random_range(0..20) {
        0 => Vec2::ZERO,
        1 => Vec2::splat(0.5),
        2 => Vec2::new(ALMOST_ONE, rng.random()),
        3 => Vec2::new(rng.random(), ALMOST_ONE),
        _ => Vec2::new(rng.random(), rng.random()),
    }
}

/// Seeded random cases over every material corner: roughness 0 and 1 (and out of range, to
/// test clamping), metallic 0, 0.5 and 1, black, white and colored bases.
fn brdf_cases() -> Vec<BrdfCase> {
    let mut rng = Pcg32::seed_from_u64(0x6272_6466);
    // Normals with z = +-0.0 and +-1 test the frame's sign rule; the rest are random.
    let special_normals = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::new(1.0, 0.0, -0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(-0.6, -0.8, -0.0),
    ];
    (0..CASE_COUNT)
        .map(|i| {
            let roughness = match rng.random_range(0..8) {
                0 => 0.0,
                1 => 1.0,
                2 => 0.02,
                3 => -0.5,
                4 => 1.5,
                _ => rng.random(),
            };
            let metallic = [0.0, 0.5, 1.0, rng.random()][rng.random_range(0..4)];
            let base = match rng.random_range(0..6) {
                0 => Vec3::ZERO,
                1 => Vec3::ONE,
                2 => Vec3::X,
                _ => Vec3::new(rng.random(), rng.random(), rng.random()),
            };
            // The dielectric layer: glTF's default, none (pure Lambert), or a random weight,
            // color (past 1 too, as KHR_materials_specular allows) and ior (0 included).
            let (specular_weight, specular_color, ior) = match rng.random_range(0..4) {
                0 | 1 => (1.0, Vec3::ONE, 1.5),
                2 => (0.0, Vec3::ONE, 1.5),
                _ => (
                    rng.random(),
                    Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0,
                    [0.0, 1.0, 1.33, rng.random_range(1.0..3.0)][rng.random_range(0..4)],
                ),
            };
            let wo = direction(&mut rng);
            let wi = incident_direction(&mut rng, wo);
            let normal = special_normals
                .get(i)
                .copied()
                .unwrap_or_else(|| unit_vector(&mut rng));
            BrdfCase {
                base: base.into(),
                metallic,
                wo: wo.into(),
                roughness,
                wi: wi.into(),
                u_lobe: rng.random(),
                normal: normal.into(),
                pdf_a: heuristic_pdf(&mut rng),
                u: warp_input(&mut rng).into(),
                pdf_b: heuristic_pdf(&mut rng),
                ior,
                specular_color: specular_color.into(),
                specular_weight,
            }
        })
        .collect()
}

/// Runs `entry_point` of the parity shader over `inputs` (one invocation each) and reads back
/// `outputs_per_input` outputs per input.
fn run_kernel<I: Pod, O: Pod>(
    ctx: &GpuContext,
    entry_point: &str,
    inputs: &[I],
    outputs_per_input: usize,
) -> Vec<O> {
    let module = ShaderLibrary::new()
        .create_module(ctx, SHADER, &[])
        .unwrap_or_else(|err| panic!("{err}"));
    let label = format!("test/{entry_point}");
    let pipeline = ctx.create_compute_pipeline(&label, &module, entry_point);
    let input_buffer = ctx.create_buffer_init(
        &format!("test.{entry_point}.inputs"),
        bytemuck::cast_slice(inputs),
        wgpu::BufferUsages::STORAGE,
    );
    let output_buffer = ctx.create_buffer(
        &format!("test.{entry_point}.outputs"),
        (inputs.len() * outputs_per_input * size_of::<O>()) as u64,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input_buffer.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output_buffer.as_entire_binding(),
            },
        ],
    });
    let mut encoder = ctx.create_encoder(&label);
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(&label),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(inputs.len().div_ceil(WORKGROUP_SIZE) as u32, 1, 1);
    }
    ctx.submit_and_wait(encoder);
    ctx.read_buffer(&output_buffer)
}

/// Comparisons of one quantity: counts, the worst error as a fraction of its tolerance, and
/// the first failures.
struct Check {
    name: &'static str,
    compared: usize,
    /// Cases whose tolerance is mostly the condition term rather than the f32 bound.
    condition_dominated: usize,
    /// Comparisons where the GPU's bits equal the CPU's.
    identical: usize,
    worst_ratio: f32,
    failures: Vec<String>,
}

impl Check {
    fn new(name: &'static str) -> Self {
        Self {
            name,
            compared: 0,
            condition_dominated: 0,
            identical: 0,
            worst_ratio: 0.0,
            failures: Vec::new(),
        }
    }

    /// Checks `|gpu - cpu| <= bound + condition`; equal infinities and two NaNs agree.
    fn value(&mut self, case: usize, gpu: f32, cpu: f32, bound: f32, condition: f32) {
        self.compared += 1;
        if condition > bound {
            self.condition_dominated += 1;
        }
        if gpu.to_bits() == cpu.to_bits() {
            self.identical += 1;
        }
        if gpu == cpu || (gpu.is_nan() && cpu.is_nan()) {
            return;
        }
        let tolerance = bound + condition;
        let ratio = (gpu - cpu).abs() / tolerance;
        // A NaN ratio is a NaN against a number.
        if ratio.is_nan() || ratio > 1.0 {
            if self.failures.len() < 10 {
                self.failures.push(format!(
                    "{} case {case}: gpu {gpu:e} cpu {cpu:e} tolerance {tolerance:e}",
                    self.name
                ));
            }
            self.worst_ratio = f32::INFINITY;
        } else {
            self.worst_ratio = self.worst_ratio.max(ratio);
        }
    }

    fn vector(&mut self, case: usize, gpu: [f32; 3], cpu: Vec3, bound: f32, condition: Vec3) {
        for axis in 0..3 {
            self.value(case, gpu[axis], cpu[axis], bound, condition[axis]);
        }
    }

    fn print(&self) {
        eprintln!(
            "{:<18} {:>6} compared, {:>6} bit-identical, worst error {:.4} of tolerance, \
             {} condition-dominated",
            self.name, self.compared, self.identical, self.worst_ratio, self.condition_dominated
        );
    }
}

/// Prints every check and fails with the failures of all of them; also fails when the
/// condition term dominates in more than half of a check's comparisons, which would mean the
/// strict bound hardly tested anything.
fn assert_checks(checks: &[&Check]) {
    let mut failures = Vec::new();
    for check in checks {
        check.print();
        failures.extend(check.failures.iter().cloned());
        if check.condition_dominated * 2 > check.compared {
            failures.push(format!(
                "{}: the condition term dominates {} of {} comparisons",
                check.name, check.condition_dominated, check.compared
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Sign patterns for perturbing six components (wo then wi, or u and v): each component moves
/// both ways and in varied combinations.
const SIGN_PATTERNS: [u32; 8] = [
    0b000000, 0b111111, 0b010101, 0b101010, 0b001100, 0b110011, 0b100001, 0b011110,
];

/// Signs (+1 or -1) of three components, from bits `first_bit..first_bit + 3` of `pattern`.
fn signs(pattern: u32, first_bit: u32) -> Vec3 {
    let sign = |bit: u32| if (pattern >> bit) & 1 == 1 { 1.0 } else { -1.0 };
    Vec3::new(sign(first_bit), sign(first_bit + 1), sign(first_bit + 2))
}

/// How far `value(wo, wi)` moves, per component, when `wo` and `wi` move by
/// [`DIRECTION_PERTURBATION`].
fn direction_condition(wo: Vec3, wi: Vec3, value: impl Fn(Vec3, Vec3) -> Vec3) -> Vec3 {
    let center = value(wo, wi);
    SIGN_PATTERNS
        .iter()
        .map(|&p| {
            let moved = value(
                wo + DIRECTION_PERTURBATION * signs(p, 0),
                wi + DIRECTION_PERTURBATION * signs(p, 3),
            );
            (moved - center).abs()
        })
        .fold(Vec3::ZERO, Vec3::max)
}

/// `u` moved by [`SAMPLE_PERTURBATION`] in each pattern of [`SIGN_PATTERNS`], kept inside
/// the unit square.
fn perturbed(u: Vec2) -> impl Iterator<Item = Vec2> {
    SIGN_PATTERNS.iter().map(move |&p| {
        let s = signs(p, 0);
        (u + SAMPLE_PERTURBATION * Vec2::new(s.x, s.y)).clamp(Vec2::ZERO, Vec2::ONE)
    })
}

/// Whether `u` lies within [`SAMPLE_PERTURBATION`] of the unit square's boundary, which the
/// warps map to the horizon.
fn on_square_boundary(u: Vec2) -> bool {
    u.min_element() <= SAMPLE_PERTURBATION || u.max_element() >= 1.0 - SAMPLE_PERTURBATION
}

/// How far a sampled direction moves when `u` moves by [`SAMPLE_PERTURBATION`] (samples that
/// become invalid are skipped: validity is checked on its own).
fn sample_condition(u: Vec2, warp: impl Fn(Vec2) -> Option<Vec3>) -> Vec3 {
    let Some(center) = warp(u) else {
        return Vec3::ZERO;
    };
    perturbed(u)
        .filter_map(|u| Some((warp(u)? - center).abs()))
        .fold(Vec3::ZERO, Vec3::max)
}

#[test]
fn parity_structs_match_their_wgsl_layout() {
    let module = ShaderLibrary::new().compose(SHADER, &[]).unwrap();
    let wgsl = wgsl_struct_layout(&module, "BrdfCase").expect("BrdfCase");
    let rust = rust_field_offsets!(BrdfCase {
        base,
        metallic,
        wo,
        roughness,
        wi,
        u_lobe,
        normal,
        pdf_a,
        u,
        pdf_b,
        ior,
        specular_color,
        specular_weight,
    });
    assert_eq!(wgsl.members, rust);
    assert_eq!(wgsl.size as usize, size_of::<BrdfCase>());

    let wgsl = wgsl_struct_layout(&module, "BrdfResult").expect("BrdfResult");
    let rust = rust_field_offsets!(BrdfResult {
        f,
        pdf,
        f0,
        specular_probability,
        diffuse_albedo,
        alpha,
        sample_wi,
        sample_pdf,
        sample_f,
        sample_valid,
        cosine_wi,
        heuristic_weight,
        frame_x,
        triangle_b1,
        frame_y,
        triangle_b2,
        local,
        base_luminance,
        world,
        split_sum_albedo,
        dielectric_reflectance,
        grazing_reflectance,
    });
    assert_eq!(wgsl.members, rust);
    assert_eq!(wgsl.size as usize, size_of::<BrdfResult>());
}

#[test]
fn brdf_matches_the_reference() {
    let Some(ctx) = GpuContext::new_or_skip("brdf_matches_the_reference") else {
        return;
    };
    let cases = brdf_cases();
    let results: Vec<BrdfResult> = run_kernel(&ctx, "brdf_parity", &cases, 1);

    let mut construction = Check::new("construction");
    let mut series = Check::new("albedo series");
    let mut eval = Check::new("eval");
    let mut pdf = Check::new("pdf");
    let mut sample_wi = Check::new("sample wi");
    let mut sample_f = Check::new("sample f");
    let mut sample_pdf = Check::new("sample pdf");
    let mut sample_valid = Check::new("sample validity");
    let (mut excluded_on_boundary, mut excluded_inside) = (0, 0);
    for (i, (case, gpu)) in cases.iter().zip(&results).enumerate() {
        let brdf = case.brdf();
        let (wo, wi) = (Vec3::from(case.wo), Vec3::from(case.wi));
        let short =
            |c: &mut Check, g: [f32; 3], v: Vec3| c.vector(i, g, v, SHORT_TOLERANCE, Vec3::ZERO);
        construction.value(i, gpu.alpha, brdf.alpha, SHORT_TOLERANCE, 0.0);
        short(&mut construction, gpu.f0, brdf.f0());
        short(
            &mut construction,
            gpu.dielectric_reflectance,
            brdf.specular.reflectance,
        );
        construction.value(i, gpu.grazing_reflectance, brdf.f90(), SHORT_TOLERANCE, 0.0);
        series.vector(
            i,
            gpu.diffuse_albedo,
            brdf.diffuse_albedo(wo.z),
            SERIES_TOLERANCE,
            Vec3::ZERO,
        );
        let p_specular = brdf.specular_probability(wo);
        construction.value(
            i,
            gpu.specular_probability,
            p_specular,
            SHORT_TOLERANCE,
            0.0,
        );
        construction.value(
            i,
            gpu.base_luminance,
            luminance(case.base.into()),
            SHORT_TOLERANCE,
            0.0,
        );
        series.value(
            i,
            gpu.split_sum_albedo,
            specular_albedo(brdf.f0(), brdf.f90(), case.roughness, wo.z).y,
            SERIES_TOLERANCE,
            0.0,
        );

        compare_value(
            &mut eval,
            i,
            gpu.f,
            brdf.eval(wo, wi),
            |wo, wi| brdf.eval(wo, wi),
            wo,
            wi,
        );
        let pdf_vec = |wo, wi| Vec3::splat(brdf.pdf(wo, wi));
        compare_value(&mut pdf, i, [gpu.pdf; 3], pdf_vec(wo, wi), pdf_vec, wo, wi);

        // The sample: same validity and lobe, then direction, then value and pdf at the GPU's
        // direction.
        let u = Vec2::from(case.u);
        let cpu = brdf.sample(wo, case.u_lobe, u);
        let gpu_wi = Vec3::from(gpu.sample_wi);
        let gpu_valid = gpu.sample_valid == 1;
        if cpu.is_some() != gpu_valid {
            // Validity is decided by `wi.z > 0` and the lobe by `u_lobe < p_specular`; where
            // either is within rounding of its threshold, f32 implementations may differ.
            let near_lobe_threshold = (case.u_lobe - p_specular).abs() < DIRECTION_TOLERANCE;
            let validity_flips =
                perturbed(u).any(|u| brdf.sample(wo, case.u_lobe, u).is_some() != cpu.is_some());
            if !(near_lobe_threshold || validity_flips) {
                sample_valid.failures.push(format!(
                    "case {i}: gpu valid {gpu_valid}, cpu {cpu:?}, gpu wi {gpu_wi}: {case:?}"
                ));
            } else if on_square_boundary(u) {
                excluded_on_boundary += 1;
            } else {
                excluded_inside += 1;
            }
            continue;
        }
        sample_valid.value(
            i,
            f32::from(u8::from(gpu_valid)),
            f32::from(u8::from(cpu.is_some())),
            0.0,
            0.0,
        );
        let Some(cpu) = cpu else {
            continue;
        };
        let condition = sample_condition(u, |u| brdf.sample(wo, case.u_lobe, u).map(|s| s.wi));
        sample_wi.vector(i, gpu.sample_wi, cpu.wi, DIRECTION_TOLERANCE, condition);
        let eval_at = |wo, wi| brdf.eval(wo, wi);
        compare_value(
            &mut sample_f,
            i,
            gpu.sample_f,
            eval_at(wo, gpu_wi),
            eval_at,
            wo,
            gpu_wi,
        );
        compare_value(
            &mut sample_pdf,
            i,
            [gpu.sample_pdf; 3],
            pdf_vec(wo, gpu_wi),
            pdf_vec,
            wo,
            gpu_wi,
        );
    }
    eprintln!(
        "sample validity: {excluded_on_boundary} cases excluded with u on the square's \
         boundary, {excluded_inside} with u inside"
    );
    // The warps map the square's boundary to the horizon, where a direction's z is all
    // rounding (`1 - |d|^2` cancels), so validity there is a coin toss between any two f32
    // implementations; inside the square a threshold is rarely within rounding.
    assert!(
        excluded_inside * 100 <= CASE_COUNT,
        "{excluded_inside} cases excluded with u inside the square"
    );
    assert_checks(&[
        &construction,
        &series,
        &eval,
        &pdf,
        &sample_valid,
        &sample_wi,
        &sample_f,
        &sample_pdf,
    ]);
}

/// Compares a BRDF value or pdf with the value bound plus its measured condition.
fn compare_value(
    check: &mut Check,
    case: usize,
    gpu: [f32; 3],
    cpu: Vec3,
    value: impl Fn(Vec3, Vec3) -> Vec3,
    wo: Vec3,
    wi: Vec3,
) {
    let condition = direction_condition(wo, wi, value);
    for axis in 0..3 {
        let bound = VALUE_TOLERANCE * cpu[axis].abs().max(1.0);
        check.value(case, gpu[axis], cpu[axis], bound, condition[axis]);
    }
}

#[test]
fn warps_heuristic_and_frames_match_the_reference() {
    let Some(ctx) = GpuContext::new_or_skip("warps_heuristic_and_frames_match_the_reference")
    else {
        return;
    };
    let cases = brdf_cases();
    let results: Vec<BrdfResult> = run_kernel(&ctx, "brdf_parity", &cases, 1);

    let mut cosine = Check::new("cosine_hemisphere");
    let mut triangle = Check::new("uniform_triangle");
    let mut heuristic = Check::new("power_heuristic");
    let mut frame = Check::new("frame");
    for (i, (case, gpu)) in cases.iter().zip(&results).enumerate() {
        let u = Vec2::from(case.u);
        let condition = sample_condition(u, |u| Some(cosine_hemisphere(u)));
        cosine.vector(
            i,
            gpu.cosine_wi,
            cosine_hemisphere(u),
            DIRECTION_TOLERANCE,
            condition,
        );

        let b = uniform_triangle(u);
        triangle.value(i, gpu.triangle_b1, b.x, SHORT_TOLERANCE, 0.0);
        triangle.value(i, gpu.triangle_b2, b.y, SHORT_TOLERANCE, 0.0);

        let weight = power_heuristic(case.pdf_a, case.pdf_b);
        heuristic.value(i, gpu.heuristic_weight, weight, SHORT_TOLERANCE, 0.0);
        if [0.0, 1.0].contains(&weight) {
            // The extremes (a pdf of 0 or infinity) are exact, not merely close.
            assert_eq!(gpu.heuristic_weight, weight, "case {i}: {case:?}");
        }

        let f = Frame::from_normal(case.normal.into());
        let wo = Vec3::from(case.wo);
        frame.vector(i, gpu.frame_x, f.x, SHORT_TOLERANCE, Vec3::ZERO);
        frame.vector(i, gpu.frame_y, f.y, SHORT_TOLERANCE, Vec3::ZERO);
        frame.vector(i, gpu.local, f.to_local(wo), SHORT_TOLERANCE, Vec3::ZERO);
        frame.vector(i, gpu.world, f.to_world(wo), SHORT_TOLERANCE, Vec3::ZERO);
    }
    assert_checks(&[&cosine, &triangle, &heuristic, &frame]);
}

#[test]
fn sampler_sequences_equal_the_reference() {
    let Some(ctx) = GpuContext::new_or_skip("sampler_sequences_equal_the_reference") else {
        return;
    };
    // Seeds with high bits set, the largest pixel index and sample indices up to u32::MAX.
    let seeds = [0, 1, 7, 1 << 32, 0xdead_beef_cafe_f00d, u64::MAX];
    let pixels = [0u32, 1, 12_345, (1 << 26) - 1];
    let samples = [0u32, 1, 255, 65_536, u32::MAX];
    let mut inputs = Vec::new();
    for seed in seeds {
        for pixel in pixels {
            for sample in samples {
                inputs.push([seed as u32, (seed >> 32) as u32, pixel, sample]);
            }
        }
    }
    let gpu: Vec<u32> = run_kernel(&ctx, "sampler_parity", &inputs, SEQUENCE_LENGTH);
    for (input, gpu) in inputs.iter().zip(gpu.chunks(SEQUENCE_LENGTH)) {
        let seed = u64::from(input[0]) | u64::from(input[1]) << 32;
        let mut sampler = Sampler::new(seed, input[2].into(), input[3].into());
        let cpu: Vec<u32> = (0..SEQUENCE_LENGTH / 2)
            .flat_map(|_| sampler.next_2d().to_array())
            .map(f32::to_bits)
            .collect();
        assert_eq!(
            gpu, cpu,
            "seed {seed}, pixel {}, sample {}",
            input[2], input[3]
        );
    }
    eprintln!(
        "{} sampler sequences of {SEQUENCE_LENGTH} numbers are bit-identical",
        inputs.len()
    );
}

#[test]
fn pcg32_equals_rand_pcg() {
    let Some(ctx) = GpuContext::new_or_skip("pcg32_equals_rand_pcg") else {
        return;
    };
    let mut rng = Pcg32::seed_from_u64(0x7063_6733);
    let mut pairs = vec![
        (0, 0),
        (u64::MAX, u64::MAX),
        (0xcafe_f00d_d15e_a5e5, 0xa02_bdbf_7bb3_c0a7),
    ];
    pairs.extend((0..61).map(|_| (rng.random::<u64>(), rng.random::<u64>())));
    let inputs: Vec<[u32; 4]> = pairs
        .iter()
        .map(|&(state, stream)| {
            [
                state as u32,
                (state >> 32) as u32,
                stream as u32,
                (stream >> 32) as u32,
            ]
        })
        .collect();
    let gpu: Vec<u32> = run_kernel(&ctx, "pcg32_parity", &inputs, SEQUENCE_LENGTH);
    for (&(state, stream), gpu) in pairs.iter().zip(gpu.chunks(SEQUENCE_LENGTH)) {
        let mut pcg = Pcg32::new(state, stream);
        let cpu: Vec<u32> = (0..SEQUENCE_LENGTH).map(|_| pcg.next_u32()).collect();
        assert_eq!(gpu, cpu, "state {state:#x}, stream {stream:#x}");
    }
}
