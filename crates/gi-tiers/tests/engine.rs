//! The renderer as an engine drives it: built by name on the engine's device, one request per
//! frame with its camera and time, nodes and lights changed between frames, and the frame read
//! as textures on the engine's device.

use gi_gpu::{GpuContext, wgpu};
use gi_image::Image;
use gi_reference::{Mode, Reference, RenderSettings};
use gi_scene::{CameraView, LightKind, Scene};
use gi_tiers::{
    CameraMode, FrameRequest, PcConfig, PcTier, Renderer, TierChoice, TierError, TierKind,
    TierSettings,
};
use glam::camera::rh;
use glam::{Mat4, Quat, Vec3};

const CPU_SETTINGS: TierSettings = TierSettings {
    width: 24,
    height: 16,
    spp: 2,
    seed: 7,
    textures: gi_tiers::TextureOptions::DEFAULT,
};

/// A grey ground under a constant sky and a sun, with a movable grey square standing on it: the sun casts its
/// shadow on the ground. Returns the scene and the square's node.
fn ground_with_a_movable_square() -> (Scene, usize) {
    let mut scene = Scene {
        name: "engine-ground".into(),
        sky: gi_scene::Sky::Constant {
            radiance: Vec3::ONE,
        },
        exposure: 1.0,
        ..Default::default()
    };
    scene.add_diffuse_quad(Vec3::ZERO, Vec3::Z * 10.0, Vec3::X * 10.0, 0.5);
    scene.lights.push(gi_scene::Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: 3.0,
        range: None,
    });
    scene.nodes.push(gi_scene::Node {
        light: Some(0),
        rotation: Quat::from_rotation_x(-1.0),
        ..gi_scene::Node::default()
    });
    scene.add_diffuse_quad(Vec3::new(0.0, 1.0, 0.0), Vec3::X, Vec3::Y, 0.8);
    let square = scene.nodes.len() - 1;
    scene.nodes[square].movable = true;
    (scene, square)
}

fn camera() -> CameraView {
    CameraView::look_at(Vec3::new(0.0, 3.0, 6.0), Vec3::new(0.0, 0.5, 0.0), 0.9)
}

/// What the reference crate renders of `scene` at time 0 through `view`.
fn reference_image(scene: &Scene, view: CameraView, settings: &TierSettings) -> Image {
    Reference::new(scene, scene.evaluate(0.0, Some(view)))
        .render(
            &RenderSettings {
                width: settings.width,
                height: settings.height,
                spp: settings.spp,
                seed: settings.seed,
                mode: Mode::Full,
                ..RenderSettings::default()
            },
            &|_| {},
        )
        .unwrap()
        .image
}

fn reference_renderer(scene: Scene) -> Renderer {
    Renderer::builder(scene)
        .tier(TierKind::Reference)
        .settings(CPU_SETTINGS)
        .build()
        .unwrap()
}

#[test]
fn a_tier_choice_is_auto_or_a_tier_name() {
    assert_eq!("auto".parse::<TierChoice>().unwrap(), TierChoice::Auto);
    assert_eq!(
        "pc".parse::<TierChoice>().unwrap(),
        TierChoice::Tier(TierKind::Pc)
    );
    let unknown = "ultra".parse::<TierChoice>().unwrap_err().to_string();
    assert!(
        unknown.contains("ultra") && unknown.contains("auto, reference"),
        "{unknown}"
    );
}

#[test]
fn a_request_sets_the_frames_camera() {
    let (scene, _) = ground_with_a_movable_square();
    let expected = reference_image(&scene, camera(), &CPU_SETTINGS);
    let mut renderer = reference_renderer(scene);
    let output = renderer
        .render(&FrameRequest::at(0.0).with_camera(camera()))
        .unwrap();
    assert_eq!(output.image.pixels, expected.pixels);
    // Without a camera the request renders the scene's own framing: another image.
    let framed = renderer.render(&FrameRequest::at(0.0)).unwrap();
    assert_ne!(framed.image.pixels, expected.pixels);
    assert_eq!(renderer.next_frame(), 2);
}

#[test]
fn an_engines_view_and_projection_make_the_same_camera() {
    let view = camera();
    let matrices = rh::view::look_at_mat4(view.position, view.position + view.forward, Vec3::Y);
    // OpenGL's convention (clip y up, depth in [-1, 1]) and Vulkan's (y down, [0, 1]).
    for projection in [
        rh::proj::opengl::perspective(view.yfov, 1.5, 0.1, 100.0),
        rh::proj::vulkan::perspective(view.yfov, 1.5, 0.1, 100.0),
    ] {
        let request = FrameRequest::default()
            .with_view_projection(&matrices, &projection)
            .unwrap();
        let made = request.camera.unwrap();
        assert!((made.position - view.position).length() < 1e-4, "{made:?}");
        assert!(made.forward.dot(view.forward) > 1.0 - 1e-6, "{made:?}");
        assert!(made.up.dot(view.up) > 1.0 - 1e-6, "{made:?}");
        assert!((made.yfov - view.yfov).abs() < 1e-5, "{made:?}");
    }
    let projection = rh::proj::vulkan::perspective(view.yfov, 1.5, 0.1, 100.0);
    let orthographic = rh::proj::opengl::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0);
    let refused = FrameRequest::default().with_view_projection(&matrices, &orthographic);
    assert!(
        matches!(refused, Err(TierError::InvalidRequest(_))),
        "{refused:?}"
    );
    let singular = FrameRequest::default().with_view_projection(&Mat4::ZERO, &projection);
    assert!(
        matches!(singular, Err(TierError::InvalidRequest(_))),
        "{singular:?}"
    );
}

#[test]
fn a_moved_node_renders_as_a_scene_built_with_it_there() {
    let (scene, square) = ground_with_a_movable_square();
    let request = FrameRequest::at(0.0).with_camera(camera());
    let mut moved_scene = scene.clone();
    moved_scene.nodes[square].translation = Vec3::new(1.5, 0.0, -1.0);
    moved_scene.nodes[square].rotation = Quat::from_rotation_y(0.6);
    let expected = reference_image(&moved_scene, camera(), &CPU_SETTINGS);

    let mut renderer = reference_renderer(scene);
    let before = renderer.render(&request).unwrap();
    renderer
        .set_node_transform(
            square,
            Vec3::new(1.5, 0.0, -1.0),
            Quat::from_rotation_y(0.6),
            Vec3::ONE,
        )
        .unwrap();
    // The same time and camera: only the node moved.
    let after = renderer.render(&request).unwrap();
    assert_ne!(
        after.image.pixels, before.image.pixels,
        "the move did not show"
    );
    assert_eq!(after.image.pixels, expected.pixels);

    // The ground is static: moving it is refused, as is a node that does not exist or a
    // transform that is not finite.
    let refused = renderer.set_node_transform(0, Vec3::X, Quat::IDENTITY, Vec3::ONE);
    assert!(
        matches!(&refused, Err(TierError::InvalidRequest(m)) if m.contains("static")),
        "{refused:?}"
    );
    let missing = renderer.set_node_transform(99, Vec3::X, Quat::IDENTITY, Vec3::ONE);
    assert!(matches!(missing, Err(TierError::InvalidRequest(_))));
    let nan = Vec3::new(f32::NAN, 0.0, 0.0);
    let not_finite = renderer.set_node_transform(square, nan, Quat::IDENTITY, Vec3::ONE);
    assert!(matches!(not_finite, Err(TierError::InvalidRequest(_))));
}

#[test]
fn a_light_edit_reaches_the_next_frame_of_a_static_scene() {
    let (mut scene, _) = ground_with_a_movable_square();
    scene.nodes.iter_mut().for_each(|node| node.movable = false);
    assert!(!scene.is_animated());
    let request = FrameRequest::at(0.0).with_camera(camera());
    let mut brighter = scene.clone();
    brighter.lights[0].intensity = 6.0;
    brighter.lights[0].color = Vec3::new(1.0, 0.5, 0.25);
    let expected = reference_image(&brighter, camera(), &CPU_SETTINGS);

    let mut renderer = reference_renderer(scene);
    let before = renderer.render(&request).unwrap();
    let light = renderer.light_mut(0).expect("the sun");
    light.intensity = 6.0;
    light.color = Vec3::new(1.0, 0.5, 0.25);
    let after = renderer.render(&request).unwrap();
    assert_ne!(after.image.pixels, before.image.pixels);
    assert_eq!(after.image.pixels, expected.pixels);
    assert!(renderer.light_mut(5).is_none());
}

/// A context on a device opened the way an engine opens its own, with the adapter's limits.
fn engine_device() -> Option<GpuContext> {
    GpuContext::new_or_skip("engine_device")?;
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default())).ok()?;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .ok()?;
    Some(GpuContext::from_device(&adapter, device, queue))
}

/// `a` and `b` agree to half-float precision: relative 2^-10 (twice f16's rounding) plus
/// f16's smallest normal, per channel.
fn assert_half_equal(a: &Image, b: &Image, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let bound = p.abs().max(q.abs()) * (2.0f32).powi(-10) + Vec3::splat(6.2e-5);
        assert!(
            (*p - *q).abs().cmple(bound).all(),
            "{what}: pixel {i}: {p} against {q}"
        );
    }
}

#[test]
fn the_frame_is_a_texture_on_the_engines_device() {
    let Some(engine) = engine_device() else {
        return;
    };
    let (scene, square) = ground_with_a_movable_square();
    let settings = TierSettings {
        width: 32,
        height: 24,
        spp: 1,
        seed: 7,
        textures: gi_tiers::TextureOptions::DEFAULT,
    };
    let restir_off = PcConfig::without("restir").unwrap();
    let mut renderer = Renderer::builder(scene)
        .tier(TierKind::Pc)
        .settings(settings)
        .pc_config(restir_off.clone())
        .camera_mode(CameraMode::Default)
        .context(engine.share())
        .build()
        .unwrap();
    assert!(
        renderer.output_textures().unwrap().is_none(),
        "no frame yet"
    );
    let tier_ctx = renderer.context().expect("a GPU tier");
    assert!(tier_ctx.shares_device_with(&engine));
    let pc = renderer.tier_as::<PcTier>().expect("the PC tier");
    assert_eq!(pc.config(), &restir_off, "the builder's configuration");

    let mut request = FrameRequest::at(0.0).with_camera(camera());
    for frame in 0..3 {
        request.time_s = Some(frame as f32 / 60.0);
        renderer.submit(&request).unwrap();
        let x = 0.2 * frame as f32;
        (renderer.set_node_transform(square, Vec3::new(x, 0.0, 0.0), Quat::IDENTITY, Vec3::ONE))
            .unwrap();
    }
    renderer.flush_frames();
    let output = renderer.render(&request).unwrap();
    let gi = renderer
        .tier_as::<PcTier>()
        .unwrap()
        .frame_data()
        .unwrap()
        .gi;
    let textures = renderer.output_textures().unwrap().expect("a GPU tier");
    assert_eq!(textures.size(), (32, 24));
    assert_eq!(textures.image.format(), gi_tiers::OUTPUT_FORMAT);
    // Read through the engine's own context: the textures live on its device.
    let image = textures.read_image(&engine).unwrap();
    let gi_texture = textures.read_gi(&engine).unwrap();
    assert_half_equal(&image, &output.image, "image");
    assert_half_equal(&gi_texture, &gi, "GI term");
    assert!(gi.pixels.iter().any(|p| p.max_element() > 1e-3), "no GI");
}

#[test]
fn the_path_tier_has_an_image_texture_and_a_black_gi_term() {
    let Some(engine) = engine_device() else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let mut renderer = Renderer::builder(scene)
        .tier(TierChoice::Tier(TierKind::Path))
        .size(16, 16)
        .spp(2)
        .context(engine.share())
        .build()
        .unwrap();
    let output = renderer.render(&FrameRequest::default()).unwrap();
    let textures = renderer.output_textures().unwrap().expect("a GPU tier");
    assert_half_equal(
        &textures.read_image(&engine).unwrap(),
        &output.image,
        "image",
    );
    let gi = textures.read_gi(&engine).unwrap();
    assert!(gi.pixels.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn a_gpu_tier_renders_a_moved_node_as_a_scene_built_with_it_there() {
    let Some(engine) = engine_device() else {
        return;
    };
    let (scene, square) = ground_with_a_movable_square();
    let place = (Vec3::new(-1.0, 0.3, 0.5), Quat::from_rotation_y(-0.8));
    let mut moved_scene = scene.clone();
    moved_scene.nodes[square].translation = place.0;
    moved_scene.nodes[square].rotation = place.1;
    let (before, after) = path_frames(scene, engine.share(), |renderer| {
        (renderer.set_node_transform(square, place.0, place.1, Vec3::ONE)).unwrap();
    });
    // The move restarts the accumulation: the frame after it holds the first samples again,
    // as the first frame of a renderer of the moved scene does.
    let (built_there, _) = path_frames(moved_scene, engine.share(), |_| {});
    assert_ne!(before.pixels, after.pixels, "the move did not show");
    // The same rays hit the same triangles, through a refitted BVH or a fresh one: f32
    // rounding apart, the images agree.
    assert_within_rounding(&after, &built_there);
}

/// On the GPU path tier (24 x 16, 4 spp, on `ctx`): the first frame of `scene` through the
/// test camera, then `edit` applied to the renderer, then the next frame.
fn path_frames(scene: Scene, ctx: GpuContext, edit: impl FnOnce(&mut Renderer)) -> (Image, Image) {
    let request = FrameRequest::at(0.0).with_camera(camera());
    let mut renderer = Renderer::builder(scene)
        .tier(TierKind::Path)
        .size(24, 16)
        .spp(4)
        .context(ctx)
        .build()
        .unwrap();
    let first = renderer.render(&request).unwrap().image;
    edit(&mut renderer);
    (first, renderer.render(&request).unwrap().image)
}

/// `a` and `b` agree pixel by pixel up to f32 rounding (relative 1e-4).
fn assert_within_rounding(a: &Image, b: &Image) {
    for (i, (a, b)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let bound = a.abs().max(b.abs()) * 1e-4 + Vec3::splat(1e-6);
        assert!(
            (*a - *b).abs().cmple(bound).all(),
            "pixel {i}: {a} against {b}"
        );
    }
}

/// The square of [`ground_with_a_movable_square`] repainted and made to glow: its material's
/// base color and emission edited.
fn repainted(material: &gi_scene::Material) -> gi_scene::Material {
    gi_scene::Material {
        base_color: glam::Vec4::new(0.9, 0.2, 0.1, 1.0),
        emissive: Vec3::new(2.0, 1.0, 0.5),
        ..material.clone()
    }
}

#[test]
fn a_material_edit_reaches_the_next_frame_as_a_scene_built_with_it() {
    let (scene, square) = ground_with_a_movable_square();
    let material = scene.meshes[scene.nodes[square].mesh.unwrap()].primitives[0].material;
    let request = FrameRequest::at(0.0).with_camera(camera());
    let mut built = scene.clone();
    built.materials[material] = repainted(&scene.materials[material]);
    let expected = reference_image(&built, camera(), &CPU_SETTINGS);

    let mut renderer = reference_renderer(scene.clone());
    let before = renderer.render(&request).unwrap();
    // The same material again is no edit.
    (renderer.set_material(material, scene.materials[material].clone())).unwrap();
    assert_eq!(
        renderer.render(&request).unwrap().image.pixels,
        before.image.pixels
    );
    (renderer.set_material(material, repainted(&scene.materials[material]))).unwrap();
    let after = renderer.render(&request).unwrap();
    assert_ne!(after.image.pixels, before.image.pixels);
    assert_eq!(after.image.pixels, expected.pixels);
}

#[test]
fn a_gpu_tier_renders_an_edited_material_as_a_scene_built_with_it() {
    let Some(engine) = engine_device() else {
        return;
    };
    let (scene, square) = ground_with_a_movable_square();
    let material = scene.meshes[scene.nodes[square].mesh.unwrap()].primitives[0].material;
    let mut built = scene.clone();
    built.materials[material] = repainted(&scene.materials[material]);
    let (before, after) = path_frames(scene, engine.share(), |renderer| {
        let edited = repainted(&renderer.scene().materials[material]);
        renderer.set_material(material, edited).unwrap();
    });
    // The edit restarts the accumulation with the new material and emitter tables: the frame
    // after it holds the first samples of a renderer of the edited scene.
    let (built_with_it, _) = path_frames(built, engine.share(), |_| {});
    assert_ne!(before.pixels, after.pixels, "the edit did not show");
    assert_within_rounding(&after, &built_with_it);
}
