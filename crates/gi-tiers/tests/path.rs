//! The GPU tiers against the CPU reference: the same seed draws the same random numbers, so
//! the GPU must reproduce the reference's samples up to f32 rounding.

use gi_gpu::GpuContext;
use gi_image::Image;
use gi_reference::{Mode, Reference, RenderSettings};
use gi_scene::{
    AlphaMode, CameraView, Light, LightKind, Material, Mesh, Node, Primitive, Scene, SceneFrame,
    Sky, Texture, TextureEncoding, TextureRef, TextureTransform,
};
use gi_tiers::{
    CameraMode, FrameInput, GpuPathTier, Moments, Renderer, Tier, TierChoice, TierError, TierKind,
    TierSettings,
};
use glam::{Quat, Vec2, Vec3, Vec4};

const WIDTH: u32 = 24;
const HEIGHT: u32 = 16;

fn settings(spp: u32) -> TierSettings {
    TierSettings {
        width: WIDTH,
        height: HEIGHT,
        spp,
        seed: 11,
        textures: gi_tiers::TextureOptions::DEFAULT,
    }
}

/// A scene, the camera it is seen through (`None`: its default camera), the image size and the
/// scene time of the frame.
struct Case {
    scene: Scene,
    camera: Option<CameraView>,
    size: (u32, u32),
    time_s: f32,
}

impl Case {
    fn bundled(name: &str) -> Self {
        Self {
            scene: gi_scene::load(name).unwrap(),
            camera: None,
            size: (WIDTH, HEIGHT),
            time_s: 0.0,
        }
    }

    /// The same case rendered at `width` x `height`.
    fn at(self, width: u32, height: u32) -> Self {
        Self {
            size: (width, height),
            ..self
        }
    }

    fn settings(&self, spp: u32) -> TierSettings {
        TierSettings {
            width: self.size.0,
            height: self.size.1,
            ..settings(spp)
        }
    }

    fn frame(&self) -> SceneFrame {
        self.scene.evaluate(self.time_s, self.camera)
    }

    /// The frame as `Renderer` evaluates it for a GPU tier: without the normals and tangents
    /// of the meshes the GPU skins (their shading comes from the GPU skinning pass).
    fn gpu_frame(&self) -> SceneFrame {
        let evaluation = gi_scene::Evaluation {
            positions_only: gi_gpu::gpu_skinned_nodes(&self.scene),
        };
        (self.scene).evaluate_with(self.time_s, self.camera, &evaluation)
    }
}

/// Renders `frames` frames of `scene` on the GPU and returns the accumulation's moments and
/// the rays the frames traced.
fn gpu_render(
    ctx: GpuContext,
    case: &Case,
    kind: TierKind,
    spp: u32,
    frames: u32,
) -> (Moments, u64) {
    let mut tier = GpuPathTier::new(kind, case.settings(spp), ctx).unwrap();
    let (scene, frame) = (&case.scene, case.gpu_frame());
    let mut rays = 0;
    for index in 0..frames {
        let output = tier
            .render(&FrameInput {
                scene,
                frame: &frame,
                index,
                progress: None,
            })
            .unwrap();
        let trace = format!("{kind}/trace");
        assert!(output.passes.iter().any(|(name, _)| *name == trace));
        let stats = output.stats.expect("GPU tiers report their throughput");
        rays += stats.rays;
        assert_eq!(stats.samples, u64::from(case.size.0 * case.size.1 * spp));
        assert_eq!(stats.nonfinite_samples, 0);
    }
    assert!(tier.memory_bytes() > 0);
    eprintln!("{kind}: {:?}", tier.dispatch_plan().unwrap());
    (tier.moments().unwrap(), rays)
}

/// The reference's mean image, standard error and ray count for the same settings.
fn cpu_render(case: &Case, mode: Mode, spp: u32) -> (Image, Image, u64) {
    let reference = Reference::new(&case.scene, case.frame());
    let settings = RenderSettings {
        width: case.size.0,
        height: case.size.1,
        spp,
        seed: settings(spp).seed,
        mode,
        ..RenderSettings::default()
    };
    let mut accumulator = reference.accumulator(&settings).unwrap();
    accumulator.add_samples(spp);
    (
        accumulator.image(),
        accumulator.standard_error(),
        accumulator.stats().rays,
    )
}

fn close(a: Vec3, b: Vec3, relative: f32) -> bool {
    (a - b).abs().max_element() <= relative * a.abs().max(b.abs()).max_element().max(1e-3)
}

#[test]
fn direct_on_the_gpu_matches_the_reference_pixel_by_pixel() {
    let Some(ctx) = GpuContext::new_or_skip("direct_on_the_gpu_matches_the_reference") else {
        return;
    };
    direct_matches_reference(ctx, &Case::bundled("atrium"));
    direct_matches_reference(GpuContext::new().unwrap(), &textured());
}

fn direct_matches_reference(ctx: GpuContext, case: &Case) {
    let (gpu, gpu_rays) = gpu_render(ctx, case, TierKind::Direct, 4, 1);
    let (cpu, _, cpu_rays) = cpu_render(case, Mode::Direct, 4);
    // Same rays, same hits: the same camera and shadow rays are traced.
    assert_eq!(gpu_rays, cpu_rays);
    // Both draw the same jitter, so each camera ray is the same to the last bit. What remains
    // is f32 rounding: the GPU interpolates the hit point from its f32 barycentrics where the
    // reference uses f64, and about a hundred operations later (normals, texture, GGX, light
    // falloff) each carry half an ulp, about 1e-5 relative in all, with transcendental ulps
    // on top. 1e-3 leaves a wide margin. A ray that grazes an edge between two triangles may
    // hit the other one on the other processor; such pixels are rare and may differ fully.
    let agreeing = gpu
        .mean
        .pixels
        .iter()
        .zip(&cpu.pixels)
        .filter(|&(g, c)| close(*g, *c, 1e-3))
        .count();
    let total = cpu.pixels.len();
    eprintln!("direct: {agreeing} of {total} pixels agree to rounding");
    assert!(
        agreeing * 100 >= total * 97,
        "only {agreeing} of {total} pixels agree"
    );
    assert_eq!(gpu.nonfinite_samples, 0);
}

/// Checks a GPU path render against the reference's render of the same seed and sample count.
fn path_matches_reference(scene_name: &str, case: Case, spp: u32) {
    let Some(ctx) = GpuContext::new_or_skip(&format!("path_matches_reference({scene_name})"))
    else {
        return;
    };
    let (gpu, gpu_rays) = gpu_render(ctx, &case, TierKind::Path, spp, 1);
    let (cpu, cpu_error, cpu_rays) = cpu_render(&case, Mode::Full, spp);
    // The ray counts differ only by the paths that diverged.
    let relative = (gpu_rays as f64 / cpu_rays as f64 - 1.0).abs();
    assert!(
        relative < 0.01,
        "{scene_name}: {gpu_rays} GPU rays, {cpu_rays} CPU rays"
    );
    assert_eq!(gpu.nonfinite_samples, 0);

    // Identical random numbers make most paths identical up to rounding; a path that crosses
    // a threshold (Russian roulette, a lobe choice, an edge) on one side only diverges into an
    // independent sample. So most pixels agree tightly...
    let agreeing = gpu
        .mean
        .pixels
        .iter()
        .zip(&cpu.pixels)
        .filter(|&(g, c)| close(*g, *c, 1e-3))
        .count();
    let total = cpu.pixels.len();
    eprintln!("{scene_name}: {agreeing} of {total} pixels agree to rounding");
    assert!(
        agreeing * 100 >= total * 90,
        "{scene_name}: only {agreeing} of {total} pixels agree to rounding"
    );
    // ...and where they do not, both are unbiased estimates of the same pixel. Over 4x4
    // blocks the difference of the means has a standard deviation of at most
    // sqrt(se_gpu^2 + se_cpu^2) (less, since the renders are positively correlated), with the
    // standard errors measured from each render's own per-pixel variance; 5 of them bound a
    // false alarm over the (at most) 24 blocks and 3 channels at about 4e-5.
    let (width, height) = case.size;
    let block = 4;
    for by in 0..height / block {
        for bx in 0..width / block {
            let (mut g, mut c, mut variance) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let i = (y * width + x) as usize;
                    g += gpu.mean.pixels[i];
                    c += cpu.pixels[i];
                    let (eg, ec) = (gpu.standard_error.pixels[i], cpu_error.pixels[i]);
                    variance += eg * eg + ec * ec;
                }
            }
            let n = (block * block) as f32;
            let bound = 5.0 * variance.map(f32::sqrt) / n + Vec3::splat(1e-4);
            let difference = ((g - c) / n).abs();
            assert!(
                difference.cmple(bound).all(),
                "{scene_name}: block ({bx}, {by}) differs by {difference} (bound {bound})"
            );
        }
    }
    let mean = |image: &Image| image.pixels.iter().sum::<Vec3>() / total as f32;
    let image_error = cpu_error
        .pixels
        .iter()
        .zip(&gpu.standard_error.pixels)
        .map(|(a, b)| *a * *a + *b * *b)
        .sum::<Vec3>()
        .map(f32::sqrt)
        / total as f32;
    let difference = (mean(&gpu.mean) - mean(&cpu)).abs();
    eprintln!(
        "{scene_name}: image mean {} (GPU) vs {} (CPU)",
        mean(&gpu.mean),
        mean(&cpu)
    );
    assert!(
        difference
            .cmple(5.0 * image_error + Vec3::splat(1e-4))
            .all(),
        "{scene_name}: image means differ by {difference} (standard error {image_error})"
    );
}

#[test]
fn path_on_the_gpu_matches_the_reference_in_the_cornell_box() {
    path_matches_reference("cornell-box", Case::bundled("cornell-box"), 8);
}

#[test]
fn path_on_the_gpu_matches_the_reference_under_sky_and_sun() {
    path_matches_reference("atrium", Case::bundled("atrium"), 8);
}

#[test]
fn path_on_the_gpu_matches_the_reference_with_textures_and_spot_lights() {
    path_matches_reference("textured", textured(), 8);
}

#[test]
fn path_on_the_gpu_matches_the_reference_with_normal_maps_alpha_and_texture_transforms() {
    path_matches_reference("real content", real_content(), 8);
}

#[test]
fn path_on_the_gpu_matches_the_reference_on_a_bent_skinned_arm() {
    // Half way to the bend: the elbow turned by 45 degrees, so the arm's world-space level
    // holds skinned, deformed triangles.
    let case = Case {
        scene: gi_scene::generate::skinned_arm(),
        camera: Some(CameraView::look_at(
            Vec3::new(0.5, 1.5, 4.0),
            Vec3::new(0.0, 1.2, 0.0),
            0.9,
        )),
        size: (WIDTH, HEIGHT),
        time_s: 0.5 * gi_scene::generate::ARM_BENT_TIME_S,
    };
    path_matches_reference("skinned arm", case, 8);
}

/// A thousand samples per pixel in one frame, as `gi render --spp 1024` asks: more loop
/// iterations per invocation than lavapipe runs (it stops an invocation's loops after 65,535)
/// and, at a larger size, longer than a desktop GPU's watchdog allows one dispatch. The tier
/// splits them into dispatches of bounded cost, and the sum still equals the reference's.
#[test]
fn a_thousand_samples_in_one_frame_match_the_reference() {
    let case = Case::bundled("cornell-box").at(16, 12);
    path_matches_reference("cornell-box at 1024 spp", case, 1024);
}

/// A scene whose traversal the dispatches' cost estimate underrates by far: a wall of 10,000
/// quads stacked in one place (each a tenth of a millimeter beside the last), which no BVH can
/// separate, so a ray that meets the wall visits every node and tests every triangle. On
/// lavapipe the first dispatches run past the device's loop limit; the shader's loop check
/// tells the tier, which renders the frame again in smaller dispatches, and the image still
/// equals the reference's.
#[test]
fn a_scene_that_outruns_the_cost_estimate_still_matches_the_reference() {
    let quads = 10_000;
    let corners = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let wall = Primitive {
        positions: (0..quads)
            .flat_map(|q| corners.map(|c| c + Vec3::X * (1e-4 * q as f32)))
            .collect(),
        normals: vec![Vec3::Z; 4 * quads],
        uvs: vec![Vec2::ZERO; 4 * quads],
        indices: (0..quads as u32)
            .flat_map(|q| [0, 1, 2, 0, 2, 3].map(|i| 4 * q + i))
            .collect(),
        material: 0,
        ..Default::default()
    };
    let scene = Scene {
        name: "stacked-wall".into(),
        meshes: vec![Mesh {
            name: String::new(),
            weights: Vec::new(),
            primitives: vec![wall],
        }],
        materials: vec![Material {
            base_color: Vec4::new(0.8, 0.7, 0.6, 1.0),
            ..Material::default()
        }],
        nodes: vec![Node {
            mesh: Some(0),
            ..Node::default()
        }],
        sky: Sky::Constant {
            radiance: Vec3::ONE,
        },
        ..Scene::default()
    };
    let case = Case {
        scene,
        camera: Some(CameraView::look_at(
            Vec3::new(0.2, 0.1, 2.5),
            Vec3::ZERO,
            0.9,
        )),
        size: (8, 8),
        time_s: 0.0,
    };
    path_matches_reference("stacked-wall", case, 16);
}

#[test]
fn two_progressive_frames_equal_one_render_of_twice_the_samples() {
    let Some(ctx) = GpuContext::new_or_skip("two_progressive_frames") else {
        return;
    };
    let case = Case::bundled("cornell-box");
    let (progressive, progressive_rays) = gpu_render(ctx, &case, TierKind::Path, 3, 2);
    let ctx = GpuContext::new().unwrap();
    let (single, single_rays) = gpu_render(ctx, &case, TierKind::Path, 6, 1);
    assert_eq!(progressive_rays, single_rays);
    assert_eq!(progressive.samples, 6);
    // Every pixel adds the same samples in the same order either way: bit for bit equal.
    assert_eq!(progressive.mean.pixels, single.mean.pixels);
    assert_eq!(
        progressive.standard_error.pixels,
        single.standard_error.pixels
    );
}

/// A camera move restarts the accumulation without touching the geometry, and a new time of an
/// animated scene only updates the BVH's top level; either way the frame equals a fresh tier's
/// render of it bit for bit.
#[test]
fn camera_moves_and_animation_reuse_the_uploaded_geometry() {
    let Some(ctx) = GpuContext::new_or_skip("camera_moves_and_animation_reuse") else {
        return;
    };
    let scene = gi_scene::load("dynamic").unwrap();
    let mut tier = GpuPathTier::new(TierKind::Path, settings(2), ctx).unwrap();
    let render = |tier: &mut GpuPathTier, frame: &SceneFrame| {
        let input = FrameInput {
            scene: &scene,
            frame,
            index: 0,
            progress: None,
        };
        tier.render(&input).unwrap().image.pixels
    };
    let fresh = |frame: &SceneFrame| {
        let mut tier =
            GpuPathTier::new(TierKind::Path, settings(2), GpuContext::new().unwrap()).unwrap();
        render(&mut tier, frame)
    };
    let first = scene.evaluate(0.0, None);
    render(&mut tier, &first);
    let (placements, build_seconds) = tier.bvh_builds().unwrap();
    let bytes = tier.memory_bytes();

    let mut camera = first.camera;
    camera.position += Vec3::new(0.3, 0.1, -0.2);
    let moved_camera = scene.evaluate(0.0, Some(camera));
    let image = render(&mut tier, &moved_camera);
    assert_eq!(
        tier.bvh_builds(),
        Some((placements, build_seconds)),
        "camera move rebuilt"
    );
    assert_eq!(tier.moments().unwrap().samples, 2, "accumulation restarted");
    assert_eq!(tier.memory_bytes(), bytes);
    assert_eq!(image, fresh(&moved_camera));

    let later = scene.evaluate(1.3, Some(camera));
    let image = render(&mut tier, &later);
    assert_eq!(
        tier.bvh_builds(),
        Some((placements + 1, build_seconds)),
        "one top level"
    );
    assert_eq!(tier.moments().unwrap().samples, 2);
    assert_eq!(image, fresh(&later));
}

#[test]
fn path_is_unavailable_for_cpu_kinds_and_auto_follows_the_policy() {
    let Some(ctx) = GpuContext::new_or_skip("path_tier_choice") else {
        return;
    };
    let adapter = gi_tiers::select::AdapterDescription::from_context(&ctx);
    let err = GpuPathTier::new(TierKind::Reference, settings(1), ctx).err();
    assert!(
        matches!(err, Some(TierError::Unavailable { .. })),
        "{err:?}"
    );

    let scene = || gi_scene::load("cornell-box").unwrap();
    // Auto never picks the offline GPU path tracer: pc, mobile or direct on a hardware GPU,
    // the CPU reference on a software adapter (tests/select.rs has the policy).
    let auto = Renderer::new(scene(), TierChoice::Auto, settings(1), CameraMode::Default).unwrap();
    let plan = gi_tiers::select::plan(Some(&adapter), &settings(1), None);
    assert_eq!(auto.tier(), plan.chosen().kind);
    assert_ne!(auto.tier(), TierKind::Path);

    let mut path = Renderer::new(
        scene(),
        TierChoice::Tier(TierKind::Path),
        settings(1),
        CameraMode::Default,
    )
    .unwrap();
    assert_eq!(path.tier(), TierKind::Path);
    let first = path.render_frame(None).unwrap();
    assert!(first.passes.iter().any(|(name, _)| name == "path/resolve"));
    assert_eq!("path".parse::<TierKind>().unwrap(), TierKind::Path);
}

/// A hand-built scene for what the bundled ones lack: base-color, metallic-roughness and
/// emissive textures (with uvs beyond [0, 1], so wrapping counts), a double-sided textured
/// emitter, a ranged point light, a spot light and a gradient sky.
fn textured() -> Case {
    let texture = |width: u32, height: u32, seed: u32, encoding| {
        let texels: Vec<Vec4> = (0..width * height)
            .map(|i| {
                let c = |k: u32| ((i * 7 + seed * k) % 11) as f32 / 10.0;
                Vec4::new(c(1), c(3), c(5), 1.0)
            })
            .collect();
        Texture::from_linear("", width, height, encoding, &texels)
    };
    let floor = Primitive {
        positions: vec![
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, -2.0),
        ],
        normals: vec![Vec3::Y; 4],
        uvs: vec![
            Vec2::new(-0.3, -0.2),
            Vec2::new(-0.3, 1.7),
            Vec2::new(2.1, 1.7),
            Vec2::new(2.1, -0.2),
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
        ..Default::default()
    };
    // Counter-clockwise seen from below: its front faces the floor.
    let emitter = Primitive {
        positions: vec![
            Vec3::new(-0.5, 1.5, -0.5),
            Vec3::new(0.5, 1.5, -0.5),
            Vec3::new(0.0, 1.5, 0.5),
        ],
        normals: vec![Vec3::NEG_Y; 3],
        uvs: vec![Vec2::ZERO, Vec2::new(1.0, 0.2), Vec2::new(0.4, 0.9)],
        indices: vec![0, 1, 2],
        material: 1,
        ..Default::default()
    };
    let light = |kind, intensity, range| Light {
        name: String::new(),
        kind,
        color: Vec3::new(1.0, 0.9, 0.8),
        intensity,
        range,
    };
    let scene = Scene {
        meshes: vec![Mesh {
            name: String::new(),
            weights: Vec::new(),
            primitives: vec![floor, emitter],
        }],
        materials: vec![
            Material {
                base_color_texture: Some(TextureRef::new(0)),
                metallic: 0.7,
                roughness: 0.6,
                metallic_roughness_texture: Some(TextureRef::new(1)),
                ..Material::default()
            },
            Material {
                emissive: Vec3::new(3.0, 2.0, 1.0),
                emissive_texture: Some(TextureRef::new(0)),
                double_sided: true,
                ..Material::default()
            },
        ],
        textures: vec![
            texture(4, 4, 1, TextureEncoding::Srgb),
            texture(2, 2, 2, TextureEncoding::Linear),
        ],
        lights: vec![
            light(LightKind::Point, 6.0, Some(5.0)),
            light(
                LightKind::Spot {
                    inner_cone_angle: 0.3,
                    outer_cone_angle: 0.6,
                },
                20.0,
                None,
            ),
        ],
        nodes: vec![
            Node {
                mesh: Some(0),
                ..Node::default()
            },
            Node {
                light: Some(0),
                translation: Vec3::new(1.0, 1.0, 1.0),
                ..Node::default()
            },
            // Lights shine down their -Z axis: turned to point straight down.
            Node {
                light: Some(1),
                translation: Vec3::new(-1.0, 2.0, 0.0),
                rotation: Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
                ..Node::default()
            },
        ],
        sky: Sky::Gradient {
            zenith: Vec3::new(0.3, 0.4, 0.8),
            horizon: Vec3::new(0.6, 0.6, 0.5),
            ground: Vec3::new(0.1, 0.1, 0.1),
        },
        ..Scene::default()
    };
    Case {
        scene,
        camera: Some(CameraView::look_at(
            Vec3::new(0.0, 2.5, 4.0),
            Vec3::new(0.0, 0.3, 0.0),
            0.9,
        )),
        size: (WIDTH, HEIGHT),
        time_s: 0.0,
    }
}

/// What real files use and the bundled scenes lack: a floor whose base color reads
/// `TEXCOORD_1` through a `KHR_texture_transform` (offset, rotation, scale) and whose normal
/// map tilts its shading normals through tangents of both handedness, a leaf card of alpha
/// `MASK` (a checker of holes) that casts a holed shadow and lets camera rays through, and a
/// half-transparent `BLEND` pane, under a sun and a gradient sky.
fn real_content() -> Case {
    let checker_alpha: Vec<Vec4> = (0..16)
        .map(|i| {
            let (x, y) = (i % 4, i / 4);
            Vec4::new(
                0.3 + 0.1 * x as f32,
                0.6,
                0.2 + 0.1 * y as f32,
                ((x + y) % 2) as f32,
            )
        })
        .collect();
    let normals: Vec<Vec4> = (0..16)
        .map(|i| {
            let tilt = (i % 5) as f32 * 0.15 - 0.3;
            let n = Vec3::new(tilt, -0.5 * tilt, 1.0).normalize();
            (n * 0.5 + 0.5).extend(1.0)
        })
        .collect();
    let colors: Vec<Vec4> = (0..16)
        .map(|i| Vec4::new((i % 3) as f32 * 0.4 + 0.1, (i % 4) as f32 * 0.25, 0.5, 1.0))
        .collect();
    let quad = |positions: [Vec3; 4], normal: Vec3, material: usize| Primitive {
        positions: positions.to_vec(),
        normals: vec![normal; 4],
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        ..Default::default()
    };
    let mut floor = quad(
        [
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, -2.0),
        ],
        Vec3::Y,
        0,
    );
    floor.uvs1 = vec![
        Vec2::new(-0.4, 0.1),
        Vec2::new(2.3, -0.2),
        Vec2::new(2.0, 1.9),
        Vec2::new(0.2, 2.2),
    ];
    // Tangents along +X; two vertices mirrored (bitangent sign -1).
    floor.tangents = vec![
        Vec4::new(1.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, -1.0),
        Vec4::new(1.0, 0.0, 0.0, -1.0),
    ];
    let leaf = quad(
        [
            Vec3::new(-0.8, 0.3, 0.5),
            Vec3::new(0.8, 0.3, 0.5),
            Vec3::new(0.8, 1.5, 0.2),
            Vec3::new(-0.8, 1.5, 0.2),
        ],
        Vec3::Z,
        1,
    );
    let pane = quad(
        [
            Vec3::new(0.4, 0.0, -0.6),
            Vec3::new(1.6, 0.0, -0.6),
            Vec3::new(1.6, 1.2, -0.6),
            Vec3::new(0.4, 1.2, -0.6),
        ],
        Vec3::Z,
        2,
    );
    let floor_material = Material {
        base_color_texture: Some(TextureRef {
            texture: 2,
            tex_coord: 1,
            transform: TextureTransform {
                offset: Vec2::new(0.3, -0.2),
                rotation: 0.7,
                scale: Vec2::new(1.5, 0.8),
            },
        }),
        normal_texture: Some(TextureRef::new(1)),
        normal_scale: 0.8,
        metallic: 0.0,
        roughness: 0.5,
        ..Material::default()
    };
    let leaf_material = Material {
        base_color_texture: Some(TextureRef::new(0)),
        alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
        double_sided: true,
        metallic: 0.0,
        ..Material::default()
    };
    let pane_material = Material {
        base_color: Vec4::new(0.9, 0.3, 0.2, 0.5),
        alpha_mode: AlphaMode::Blend,
        metallic: 0.0,
        ..Material::default()
    };
    let scene = Scene {
        name: "real-content".into(),
        meshes: vec![Mesh {
            name: String::new(),
            weights: Vec::new(),
            primitives: vec![floor, leaf, pane],
        }],
        materials: vec![floor_material, leaf_material, pane_material],
        textures: vec![
            Texture::from_linear("leaf", 4, 4, TextureEncoding::Srgb, &checker_alpha),
            Texture::from_linear("normals", 4, 4, TextureEncoding::Linear, &normals),
            Texture::from_linear("colors", 4, 4, TextureEncoding::Srgb, &colors),
        ],
        lights: vec![Light {
            name: String::new(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity: 3.0,
            range: None,
        }],
        nodes: vec![
            Node {
                mesh: Some(0),
                ..Node::default()
            },
            Node {
                light: Some(0),
                rotation: Quat::from_rotation_x(-1.1) * Quat::from_rotation_y(0.3),
                ..Node::default()
            },
        ],
        sky: Sky::Gradient {
            zenith: Vec3::new(0.3, 0.4, 0.8),
            horizon: Vec3::new(0.6, 0.6, 0.5),
            ground: Vec3::new(0.1, 0.1, 0.1),
        },
        ..Scene::default()
    };
    Case {
        scene,
        camera: Some(CameraView::look_at(
            Vec3::new(0.3, 2.2, 3.5),
            Vec3::new(0.0, 0.4, 0.0),
            0.9,
        )),
        size: (WIDTH, HEIGHT),
        time_s: 0.0,
    }
}

/// The renderer's way of following an animated, skinned scene on a GPU tier (frames moved in
/// place, the skinned arm's normals and tangents left out and skinned on the GPU, at the
/// upload and at every update) renders the CPU reference's direct light of complete frames
/// evaluated afresh, pixel by pixel up to f32 rounding, at every frame.
#[test]
fn renderer_frames_of_a_skinned_scene_render_like_the_reference() {
    let Some(ctx) = GpuContext::new_or_skip("renderer_frames_of_a_skinned_scene") else {
        return;
    };
    // The arm fills the view, lit by a sun from the side (so its shading follows its normals).
    let mut scene = gi_scene::generate::skinned_arm();
    scene.lights.push(Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: 3.0,
        range: None,
    });
    scene.nodes.push(Node {
        light: Some(scene.lights.len() - 1),
        rotation: Quat::from_rotation_y(1.2) * Quat::from_rotation_x(-0.5),
        ..Node::default()
    });
    scene.camera_path = Some(gi_scene::CameraPath {
        keys: vec![gi_scene::CameraKey {
            time_s: 0.0,
            position: Vec3::new(0.3, 1.6, 2.2),
            target: Vec3::new(0.0, 1.4, 0.0),
        }],
        yfov: 0.9,
    });
    let settings = TierSettings {
        width: 32,
        height: 24,
        ..settings(4)
    };
    let tier = GpuPathTier::new(TierKind::Direct, settings, ctx).unwrap();
    let mut renderer = Renderer::with_tier(scene.clone(), Box::new(tier), CameraMode::Path);
    // Frames 0, 10 and 20: the elbow bends by up to 60 degrees.
    for index in 0..21u32 {
        let output = renderer.render_frame(None).unwrap();
        if index % 10 != 0 {
            continue;
        }
        let frame = scene.evaluate(scene.frame_time(index), Some(renderer.view(index)));
        let expected = Reference::new(&scene, frame)
            .render(
                &RenderSettings {
                    width: settings.width,
                    height: settings.height,
                    spp: settings.spp,
                    seed: settings.seed,
                    mode: Mode::Direct,
                    ..RenderSettings::default()
                },
                &|_| {},
            )
            .unwrap();
        let agreeing = (output.image.pixels.iter())
            .zip(&expected.image.pixels)
            .filter(|&(a, b)| close(*a, *b, 1e-3))
            .count();
        let total = expected.image.pixels.len();
        assert!(
            agreeing * 100 >= total * 97,
            "frame {index}: only {agreeing} of {total} pixels agree"
        );
    }
}
