//! The ray-cast G-buffer (`gbuffer/primary`) against CPU ray casts through the same pixel
//! centers: triangles, depth, materials and normals on bundled scenes, motion vectors against
//! the analytic reprojection, and the layouts of the structs shared with WGSL.

use gi_gpu::gbuffer::{GBUFFER_MISS, GBufferCamera, GBufferUniforms};
use gi_gpu::{
    GBuffer, GBufferData, GBufferInputs, GpuContext, GpuScene, GpuTimer, Recorder, ShaderLibrary,
    Technique, rust_field_offsets, wgsl_struct_layout,
};
use gi_scene::generate::{ARM_BENT_TIME_S, skinned_arm};
use gi_scene::{CameraView, Scene, SceneBvh, SceneFrame};
use glam::{Vec2, Vec3};

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;
/// Relative tolerance on depth: the GPU repeats the CPU's f32 operations but may fuse
/// multiply-adds differently.
const DEPTH_REL: f32 = 1e-4;
/// Least share of pixels whose triangle must match; the rest are rays through shared edges,
/// where rounding picks either neighbor.
const MIN_TRIANGLE_MATCH: f64 = 0.99;
/// Motion tolerance in pixels.
const MOTION_PX: f32 = 1e-2;

fn load(name: &str) -> Scene {
    gi_scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Renders the G-buffer of `frame` with `previous` as the previous frame.
fn render(
    ctx: &GpuContext,
    scene: &Scene,
    frame: &SceneFrame,
    previous: &SceneFrame,
) -> GBufferData {
    render_with_layer(ctx, scene, frame, previous).0
}

/// [`render`], also returning `gbuffer.blend_layer` (one entry per pixel for scenes with
/// alpha-`BLEND` materials).
fn render_with_layer(
    ctx: &GpuContext,
    scene: &Scene,
    frame: &SceneFrame,
    previous: &SceneFrame,
) -> (GBufferData, Vec<[f32; 4]>) {
    let gpu_scene = GpuScene::upload(ctx, scene, frame).expect("scene uploads");
    let mut gbuffer =
        GBuffer::new(ctx, &ShaderLibrary::new(), WIDTH, HEIGHT).expect("gbuffer/primary compiles");
    gbuffer.prepare_layers(ctx, &gpu_scene);
    let mut timer = GpuTimer::new(ctx, "gbuffer", 4);
    let mut rec = Recorder::new(ctx, &mut timer, "gbuffer");
    let inputs = GBufferInputs {
        frame,
        scene: &gpu_scene,
        previous,
    };
    gbuffer.record(&mut rec, &inputs);
    let encoder = rec.into_encoder();
    let timings = timer.finish(ctx, encoder);
    assert!(timings.get("gbuffer/primary").is_some(), "{timings}");
    let data = gbuffer.read(ctx);
    let layer = ctx.read_buffer(gbuffer.outputs().blend_layer);
    gbuffer.release(ctx);
    gpu_scene.release(ctx);
    (data, layer)
}

/// The unit camera ray through the center of pixel `(x, y)`, as the reference casts it.
fn pixel_ray(camera: &CameraView, x: u32, y: u32) -> Vec3 {
    let u = (x as f32 + 0.5) / WIDTH as f32;
    let v = (y as f32 + 0.5) / HEIGHT as f32;
    camera.ray_direction(u, v, WIDTH as f32 / HEIGHT as f32)
}

/// Pixel position of `d` (a point minus the camera position, or a direction) seen by
/// `camera`, `None` behind it.
fn project(camera: &CameraView, d: Vec3) -> Option<Vec2> {
    let z = d.dot(camera.forward);
    if z <= 0.0 {
        return None;
    }
    let tan_half = (camera.yfov * 0.5).tan();
    let aspect = WIDTH as f32 / HEIGHT as f32;
    let fx = d.dot(camera.right) / (z * tan_half * aspect);
    let fy = d.dot(camera.up) / (z * tan_half);
    Some(Vec2::new(
        0.5 * (fx + 1.0) * WIDTH as f32,
        0.5 * (1.0 - fy) * HEIGHT as f32,
    ))
}

/// Inverse of `gi::packing::pack_unit_vector` (two snorm16 octahedral coordinates).
fn unpack_unit_vector(packed: u32) -> Vec3 {
    let snorm = |bits: u32| ((bits as u16 as i16) as f32 / 32767.0).max(-1.0);
    let e = Vec2::new(snorm(packed & 0xffff), snorm(packed >> 16));
    let mut n = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    let fold = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -fold } else { fold };
    n.y += if n.y >= 0.0 { -fold } else { fold };
    n.normalize()
}

#[test]
fn primary_hits_match_cpu_ray_cast() {
    let Some(ctx) = GpuContext::new_or_skip("primary_hits_match_cpu_ray_cast") else {
        return;
    };
    for name in ["cornell-box", "glossy"] {
        let scene = load(name);
        let frame = scene.evaluate(0.0, None);
        let data = render(&ctx, &scene, &frame, &frame);
        let bvh = SceneBvh::build(&frame.triangles);
        let camera = frame.camera;
        let mut matched = 0;
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let pixel = (y * WIDTH + x) as usize;
                let dir = pixel_ray(&camera, x, y);
                let hit =
                    bvh.closest_hit(&frame.triangles, camera.position, dir, 0.0, f32::INFINITY);
                let Some(hit) = hit else {
                    if data.triangle[pixel] == GBUFFER_MISS {
                        assert_eq!(data.depth[pixel], f32::INFINITY, "{name} sky depth");
                        assert_eq!(data.base_color[pixel], [0.0; 4], "{name} sky color");
                        matched += 1;
                    }
                    continue;
                };
                if data.triangle[pixel] != hit.triangle {
                    continue;
                }
                matched += 1;
                let depth = data.depth[pixel];
                assert!(
                    (depth - hit.t).abs() <= DEPTH_REL * hit.t,
                    "{name} pixel ({x}, {y}): depth {depth} vs CPU {}",
                    hit.t
                );

                // Bundled scenes are untextured: the G-buffer holds the material's factors.
                let attributes = &frame.attributes[hit.triangle as usize];
                let default = gi_scene::Material::default();
                let material = scene
                    .materials
                    .get(attributes.material as usize)
                    .unwrap_or(&default);
                let base = data.base_color[pixel];
                assert_eq!(&base[..3], &material.base_color.truncate().to_array()[..]);
                assert_eq!(
                    base[3],
                    packed_layer(material),
                    "{name} pixel ({x}, {y}): the dielectric layer"
                );
                assert_eq!(
                    data.metallic_roughness[pixel],
                    [material.metallic, material.roughness],
                    "{name} pixel ({x}, {y})"
                );
                let tri = &frame.triangles[hit.triangle as usize];
                let ng = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0)).normalize_or_zero();
                let front = ng.dot(-dir) >= 0.0;
                let emitted = if front || material.double_sided {
                    material.emissive
                } else {
                    Vec3::ZERO
                };
                assert_eq!(&data.emissive[pixel][..3], &emitted.to_array()[..]);

                let n = unpack_unit_vector(data.normal[pixel]);
                assert!(
                    n.dot(-dir) > 0.0,
                    "{name} pixel ({x}, {y}): normal {n} faces away"
                );
            }
        }
        let share = matched as f64 / (WIDTH * HEIGHT) as f64;
        assert!(
            share >= MIN_TRIANGLE_MATCH,
            "{name}: only {share} of pixels match the CPU"
        );
    }
}

/// The Cornell box with a small texture on every material's base color, metallic-roughness
/// and emission, and UVs from the vertex positions, so texture lookups vary over each face.
/// The texture is magnified at the test's size (a texel spans several pixels), where the
/// G-buffer reads level 0 with the reference's filter.
fn textured_cornell_box() -> Scene {
    let mut scene = load("cornell-box");
    let texels: Vec<glam::Vec4> = (0..16)
        .map(|i| {
            let f = i as f32 / 15.0;
            glam::Vec4::new(
                0.2 + 0.8 * f,
                1.0 - 0.7 * f,
                0.3 + 0.5 * (i % 3) as f32 / 2.0,
                1.0,
            )
        })
        .collect();
    scene.textures.push(gi_scene::Texture::from_linear(
        "gbuffer.test_texture",
        4,
        4,
        gi_scene::TextureEncoding::Srgb,
        &texels,
    ));
    let texture = Some(gi_scene::TextureRef::new(scene.textures.len() - 1));
    for material in &mut scene.materials {
        material.base_color_texture = texture;
        material.metallic_roughness_texture = texture;
        material.emissive_texture = texture;
        material.occlusion_texture = texture;
        material.occlusion_strength = 0.7;
    }
    for mesh in &mut scene.meshes {
        for primitive in &mut mesh.primitives {
            primitive.uvs = primitive
                .positions
                .iter()
                .map(|p| Vec2::new(0.21 * p.x + 0.09 * p.y, 0.15 * p.z - 0.12 * p.y))
                .collect();
        }
    }
    scene
}

#[test]
fn textured_materials_match_cpu_lookups() {
    let Some(ctx) = GpuContext::new_or_skip("textured_materials_match_cpu_lookups") else {
        return;
    };
    let scene = textured_cornell_box();
    let frame = scene.evaluate(0.0, None);
    let data = render(&ctx, &scene, &frame, &frame);
    let bvh = SceneBvh::build(&frame.triangles);
    let camera = frame.camera;
    let texture = scene.textures.last().expect("test texture");
    let mut checked = 0;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let pixel = (y * WIDTH + x) as usize;
            let dir = pixel_ray(&camera, x, y);
            let Some(hit) =
                bvh.closest_hit(&frame.triangles, camera.position, dir, 0.0, f32::INFINITY)
            else {
                continue;
            };
            if data.triangle[pixel] != hit.triangle {
                continue;
            }
            checked += 1;
            let attributes = &frame.attributes[hit.triangle as usize];
            let material = &scene.materials[attributes.material as usize];
            let b = hit.barycentrics;
            let uv = attributes.uvs[0] * (1.0 - b.x - b.y)
                + attributes.uvs[1] * b.x
                + attributes.uvs[2] * b.y;
            let t = texture.sample_bilinear(uv);
            let close = |gpu: &[f32], cpu: Vec3, what: &str| {
                let error = (Vec3::from_slice(gpu) - cpu).abs().max_element();
                assert!(
                    error <= 1e-4,
                    "pixel ({x}, {y}) {what}: GPU {gpu:?}, CPU {cpu}"
                );
            };
            close(
                &data.base_color[pixel][..3],
                material.base_color.truncate() * t.truncate(),
                "base color",
            );
            let [metallic, roughness] = data.metallic_roughness[pixel];
            close(
                &[metallic, roughness, 0.0],
                Vec3::new(material.metallic * t.z, material.roughness * t.y, 0.0),
                "metallic-roughness",
            );
            let tri = &frame.triangles[hit.triangle as usize];
            let ng = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0));
            let emitted = if ng.dot(-dir) >= 0.0 || material.double_sided {
                material.emissive * t.truncate()
            } else {
                Vec3::ZERO
            };
            close(&data.emissive[pixel][..3], emitted, "emission");
            // The occlusion factor reads the red channel as stored (the sRGB texture decodes in
            // both places alike).
            let occlusion = 1.0 + material.occlusion_strength * (t.x - 1.0);
            close(
                &[data.emissive[pixel][3], 0.0, 0.0],
                Vec3::new(occlusion, 0.0, 0.0),
                "occlusion",
            );
        }
    }
    assert!(
        checked > (WIDTH * HEIGHT / 2) as usize,
        "too few pixels checked: {checked}"
    );
}

#[test]
fn cornell_box_normals_are_the_flat_face_normals() {
    let Some(ctx) = GpuContext::new_or_skip("cornell_box_normals_are_the_flat_face_normals") else {
        return;
    };
    let scene = load("cornell-box");
    let frame = scene.evaluate(0.0, None);
    let data = render(&ctx, &scene, &frame, &frame);
    for (pixel, &triangle) in data.triangle.iter().enumerate() {
        if triangle == GBUFFER_MISS {
            continue;
        }
        let (x, y) = (pixel as u32 % WIDTH, pixel as u32 / WIDTH);
        let dir = pixel_ray(&frame.camera, x, y);
        let tri = &frame.triangles[triangle as usize];
        let mut ng = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0)).normalize();
        if ng.dot(-dir) < 0.0 {
            ng = -ng;
        }
        let n = unpack_unit_vector(data.normal[pixel]);
        assert!(
            n.dot(ng) > 0.9999,
            "pixel ({x}, {y}): normal {n}, face normal {ng}"
        );
    }
}

#[test]
fn camera_translation_gives_the_analytic_reprojection() {
    let Some(ctx) = GpuContext::new_or_skip("camera_translation_gives_the_analytic_reprojection")
    else {
        return;
    };
    let scene = load("cornell-box");
    let frame = scene.evaluate(0.0, None);
    let mut previous_camera = frame.camera;
    previous_camera.position += Vec3::new(0.05, -0.03, 0.08);
    let previous = scene.evaluate(0.0, Some(previous_camera));
    let data = render(&ctx, &scene, &frame, &previous);
    let camera = frame.camera;
    let mut moving = 0;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let pixel = (y * WIDTH + x) as usize;
            let dir = pixel_ray(&camera, x, y);
            let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let d = if data.triangle[pixel] == GBUFFER_MISS {
                dir
            } else {
                camera.position + dir * data.depth[pixel] - previous_camera.position
            };
            let expected = project(&previous_camera, d).map_or(Vec2::ZERO, |p| p - center);
            let motion = Vec2::from(data.motion[pixel]);
            assert!(
                (motion - expected).length() <= MOTION_PX,
                "pixel ({x}, {y}): motion {motion}, analytic {expected}"
            );
            moving += usize::from(expected.length() > 0.1);
        }
    }
    assert!(moving > 0, "the camera move should shift the image");
}

#[test]
fn static_camera_moves_only_the_animated_box() {
    let Some(ctx) = GpuContext::new_or_skip("static_camera_moves_only_the_animated_box") else {
        return;
    };
    let scene = load("dynamic");
    let frame = scene.evaluate(1.0, None);
    let previous = scene.evaluate(0.9, Some(frame.camera));
    assert_eq!(frame.triangles.len(), previous.triangles.len());
    let data = render(&ctx, &scene, &frame, &previous);
    let mut moving_pixels = 0;
    for (pixel, &triangle) in data.triangle.iter().enumerate() {
        let motion = Vec2::from(data.motion[pixel]).length();
        let moved = triangle != GBUFFER_MISS && {
            let (now, then) = (
                &frame.triangles[triangle as usize],
                &previous.triangles[triangle as usize],
            );
            now.v0 != then.v0 || now.v1 != then.v1 || now.v2 != then.v2
        };
        if moved {
            moving_pixels += 1;
            assert!(
                motion > 0.0,
                "pixel {pixel} on the moving box has no motion"
            );
        } else {
            assert!(
                motion <= MOTION_PX,
                "pixel {pixel} on static geometry moves {motion} px"
            );
        }
    }
    assert!(moving_pixels > 0, "the moving box should be in view");
}

#[test]
fn gbuffer_structs_match_wgsl() {
    let module = ShaderLibrary::new()
        .compose("gbuffer/primary.wgsl", &[])
        .expect("gbuffer/primary composes");
    let camera = wgsl_struct_layout(&module, "Camera").expect("Camera");
    assert_eq!(camera.size as usize, size_of::<GBufferCamera>());
    assert_eq!(
        camera.members,
        rust_field_offsets!(GBufferCamera {
            position,
            tan_half_fov,
            right,
            aspect,
            up,
            pad_a,
            forward,
            pad_b
        })
    );
    let uniforms = wgsl_struct_layout(&module, "GBufferUniforms").expect("GBufferUniforms");
    assert_eq!(uniforms.size as usize, size_of::<GBufferUniforms>());
    assert_eq!(
        uniforms.members,
        rust_field_offsets!(GBufferUniforms {
            camera,
            previous_camera,
            size_px,
            default_material,
            has_previous_transforms,
            blend_layer_on,
            has_previous_triangles
        })
    );
}

/// `gi::brdf::pack_dielectric_specular` of an untextured material's layer, computed apart: the
/// weight in 8 bits and the largest channel of `((ior - 1) / (ior + 1))^2 * specular color`
/// in 12, as an integer-valued float, plus 1.
fn packed_layer(material: &gi_scene::Material) -> f32 {
    let r = f64::from((material.ior - 1.0) / (material.ior + 1.0));
    let f0 = (r * r * f64::from(material.specular_color.max_element())).min(1.0);
    let weight = (f64::from(material.specular.clamp(0.0, 1.0)) * 255.0).round() as u32;
    let f0 = (f0 * 4095.0).round() as u32;
    (weight * 4096 + f0 + 1) as f32
}

/// Minified textures are prefiltered: a 64x64 black-and-white checkerboard seen from afar
/// (about 16 texels per pixel) gives pixels near its mean, where one bilinear tap of level 0
/// per pixel would give values anywhere between black and white.
#[test]
fn minified_textures_read_prefiltered_mip_levels() {
    let Some(ctx) = GpuContext::new_or_skip("minified_textures_read_prefiltered_mip_levels") else {
        return;
    };
    let mut scene = gi_scene::Scene::default();
    let node = scene.add_diffuse_quad(Vec3::ZERO, Vec3::X * 4.0, Vec3::Y * 4.0, 1.0);
    let texels: Vec<glam::Vec4> = (0..64 * 64)
        .map(|i| {
            let (x, y) = (i % 64, i / 64);
            glam::Vec4::splat(((x + y) % 2) as f32)
        })
        .collect();
    scene.textures.push(gi_scene::Texture::from_linear(
        "checker",
        64,
        64,
        gi_scene::TextureEncoding::Linear,
        &texels,
    ));
    scene.materials[0].base_color_texture = Some(gi_scene::TextureRef::new(0));
    let mesh = scene.nodes[node].mesh.unwrap();
    scene.meshes[mesh].primitives[0].uvs = vec![
        Vec2::new(0.0, 1.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, 0.0),
    ];
    // The 8 m quad fills about 4 of the 30 rows: 16 texels per pixel.
    let camera = CameraView::look_at(Vec3::new(0.0, 0.0, 50.0), Vec3::ZERO, 1.2);
    let frame = scene.evaluate(0.0, Some(camera));
    let data = render(&ctx, &scene, &frame, &frame);
    let mut covered = 0;
    for (pixel, &triangle) in data.triangle.iter().enumerate() {
        if triangle == GBUFFER_MISS {
            continue;
        }
        covered += 1;
        let value = data.base_color[pixel][0];
        assert!(
            (value - 0.5).abs() < 0.1,
            "pixel {pixel}: {value}, not the checker's prefiltered mean 0.5"
        );
    }
    assert!(covered >= 4, "the quad covers {covered} pixels");
}

#[test]
fn blended_surfaces_are_a_layer_over_the_surface_behind() {
    let Some(ctx) = GpuContext::new_or_skip("blended_surfaces_are_a_layer_over_the_surface_behind")
    else {
        return;
    };
    let mut scene = load("cornell-box");
    let camera = scene.evaluate(0.0, None).camera;
    let (distance, half) = (0.5, 0.1);
    scene.add_diffuse_quad(
        camera.position + camera.forward * distance,
        camera.right * half,
        camera.up * half,
        0.5,
    );
    let glass = scene.materials.last_mut().expect("the quad's material");
    glass.alpha_mode = gi_scene::AlphaMode::Blend;
    glass.base_color.w = 0.4;
    glass.double_sided = true;
    let frame = scene.evaluate(0.0, None);
    let (data, layer) = render_with_layer(&ctx, &scene, &frame, &frame);
    assert_eq!(layer.len(), (WIDTH * HEIGHT) as usize);
    let bvh = SceneBvh::build(&frame.triangles);
    let quad = frame.triangles.len() - 2;
    let (mut covered, mut clear, mut open) = (0, 0, 0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let pixel = (y * WIDTH + x) as usize;
            let dir = pixel_ray(&frame.camera, x, y);
            let Some(first) =
                bvh.closest_hit(&frame.triangles, camera.position, dir, 0.0, f32::INFINITY)
            else {
                continue;
            };
            let [t, normal, albedo, alpha] = layer[pixel];
            if (first.triangle as usize) < quad {
                // Nothing blended in front: no layer, and the G-buffer sees the first hit.
                assert_eq!(t, 0.0, "pixel ({x}, {y})");
                open += 1;
                if data.triangle[pixel] == first.triangle {
                    clear += 1;
                }
                continue;
            }
            // The quad is the layer; the G-buffer holds the box behind it.
            covered += 1;
            assert!(
                (t - first.t).abs() <= 1e-4 * first.t,
                "pixel ({x}, {y}): {t} vs {}",
                first.t
            );
            assert!((alpha - 0.4).abs() < 1e-6, "alpha {alpha}");
            let n = unpack_unit_vector(normal.to_bits());
            assert!(n.dot(-camera.forward) > 0.999, "normal {n}");
            let rgb = glam::Vec4::from_array(
                albedo.to_bits().to_le_bytes().map(|b| f32::from(b) / 255.0),
            );
            for c in [rgb.x, rgb.y, rgb.z] {
                assert!((c * c - 0.5).abs() < 0.01, "albedo {}", c * c);
            }
            assert!(
                data.depth[pixel] > first.t + 0.1,
                "pixel ({x}, {y}) depth {}",
                data.depth[pixel]
            );
            assert!((data.triangle[pixel] as usize) < quad);
        }
    }
    assert!(covered > 20, "the quad covers only {covered} pixels");
    // Ties on triangle edges aside, the G-buffer is the plain ray cast there.
    assert!(
        clear * 100 >= open * 98,
        "{clear} of {open} pixels without a layer matched"
    );
}

/// Barycentric weights of v1 and v2 where `dir` from `origin` crosses the plane of triangle
/// `(v0, v1, v2)` (Möller-Trumbore without the range checks).
fn barycentrics(origin: Vec3, dir: Vec3, [v0, v1, v2]: [Vec3; 3]) -> Vec2 {
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = dir.cross(e2);
    let inv_det = 1.0 / e1.dot(p);
    let s = origin - v0;
    let q = s.cross(e1);
    Vec2::new(s.dot(p) * inv_det, dir.dot(q) * inv_det)
}

/// A skinned arm bending at its elbow changes the shape of its triangles, which no node
/// transform describes (its node does not move): the motion of a pixel on the arm is where the
/// same barycentric point of its triangle was in the previous frame, projected by the previous
/// camera. The previous frame's triangles are the G-buffer's own copy, made after the pass of
/// the frame before.
#[test]
fn skinned_triangles_move_with_their_vertices() {
    let Some(ctx) = GpuContext::new_or_skip("skinned_triangles_move_with_their_vertices") else {
        return;
    };
    let scene = skinned_arm();
    let camera = CameraView::look_at(Vec3::new(0.5, 1.3, 5.0), Vec3::new(0.5, 1.3, 0.0), 0.9);
    let previous = scene.evaluate(0.4 * ARM_BENT_TIME_S, Some(camera));
    let middle = scene.evaluate(0.7 * ARM_BENT_TIME_S, Some(camera));
    // The third frame reads the copy that followed the second, which rewrote only the arm.
    let frame = scene.evaluate(0.95 * ARM_BENT_TIME_S, Some(camera));
    let mut gpu_scene = GpuScene::upload(&ctx, &scene, &previous).expect("scene uploads");
    assert!(gpu_scene.has_deforming);
    let mut gbuffer =
        GBuffer::new(&ctx, &ShaderLibrary::new(), WIDTH, HEIGHT).expect("gbuffer/primary compiles");
    gbuffer.prepare_layers(&ctx, &gpu_scene);
    let mut timer = GpuTimer::new(&ctx, "gbuffer", 4);
    for (this, before) in [
        (&previous, &previous),
        (&middle, &previous),
        (&frame, &middle),
    ] {
        if !std::ptr::eq(this, before) {
            gpu_scene.update(&ctx, &scene, this).expect("scene updates");
        }
        let mut rec = Recorder::new(&ctx, &mut timer, "gbuffer");
        let inputs = GBufferInputs {
            frame: this,
            scene: &gpu_scene,
            previous: before,
        };
        gbuffer.record(&mut rec, &inputs);
        let encoder = rec.into_encoder();
        timer.finish(&ctx, encoder);
    }
    let data = gbuffer.read(&ctx);
    let arm = 3;
    let mut moving = 0;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let pixel = (y * WIDTH + x) as usize;
            let triangle = data.triangle[pixel];
            if triangle == GBUFFER_MISS {
                continue;
            }
            let (now, then) = (
                &frame.triangles[triangle as usize],
                &middle.triangles[triangle as usize],
            );
            let dir = pixel_ray(&camera, x, y);
            let b = barycentrics(
                camera.position,
                dir,
                [now.v0, now.v1, now.v2].map(Vec3::from),
            );
            let [t0, t1, t2] = [then.v0, then.v1, then.v2].map(Vec3::from);
            let was = t0 + (t1 - t0) * b.x + (t2 - t0) * b.y;
            let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let expected = project(&camera, was - camera.position).unwrap() - center;
            let motion = Vec2::from(data.motion[pixel]);
            assert!(
                (motion - expected).length() <= MOTION_PX,
                "pixel ({x}, {y}), triangle {triangle}: motion {motion}, expected {expected}"
            );
            if frame.attributes[triangle as usize].node == arm && expected.length() > 0.5 {
                moving += 1;
            }
        }
    }
    assert!(
        moving >= 10,
        "{moving} arm pixels moved more than half a pixel"
    );
}
