//! Lighting the cache (`cache/inject`, `cache/propagate`): direct injection against the
//! analytic irradiance, convergence against the reference's irradiance, reaction to a changed
//! light, and the passes' GPU times.

use gi_cache::layout::{FACE_DIRECTIONS, face_slot, mask_cell, voxel_index};
use gi_cache::lighting::{GpuLightingUniforms, GpuScheduledBrick, GpuSky};
use gi_cache::packing::{unpack_rgb9e5, unpack_unit_vector};
use gi_cache::{
    CacheBuffers, CacheConfig, CacheLighting, CpuCache, LightingInputs, LitBrick, ScheduleCounts,
};
use gi_gpu::{
    GpuContext, GpuScene, GpuTimer, PassTimings, ShaderLibrary, rust_field_offsets,
    wgsl_struct_layout,
};
use gi_scene::{
    Light, LightKind, Material, Mesh, Node, Primitive, Scene, SceneBvh, SceneFrame, Sky,
};
use glam::{IVec3, Quat, Vec2, Vec3};

#[test]
fn lighting_structs_match_their_wgsl_layout() {
    let module = ShaderLibrary::new()
        .compose("cache/inject.wgsl", &[])
        .unwrap();
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let wgsl = wgsl_struct_layout(&module, name).unwrap_or_else(|| panic!("{name}"));
        assert_eq!(wgsl.members, rust, "{name}");
        assert_eq!(wgsl.size as usize, size, "{name}");
    };
    check(
        "Sky",
        rust_field_offsets!(GpuSky {
            zenith,
            horizon,
            ground,
            kind,
            pad_a,
            pad_b,
            pad_c
        }),
        size_of::<GpuSky>(),
    );
    check(
        "LightingUniforms",
        rust_field_offsets!(GpuLightingUniforms {
            sky,
            brick_count,
            light_count,
            rays_per_face,
            max_age,
            frame_index,
            seed,
            pad_a,
            pad_b
        }),
        size_of::<GpuLightingUniforms>(),
    );
    check(
        "ScheduledBrick",
        rust_field_offsets!(GpuScheduledBrick {
            brick,
            level,
            brick_id,
            pad_a,
            pad_b,
            pad_c
        }),
        size_of::<GpuScheduledBrick>(),
    );
    ShaderLibrary::new()
        .compose("cache/propagate.wgsl", &[])
        .unwrap();
}

// ---------------------------------------------------------------------------------------------
// Scenes and a cache lit on the GPU.
// ---------------------------------------------------------------------------------------------

/// A scene assembled in code: one node per quad or light.
struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    fn new(sky: Sky) -> Self {
        Self {
            scene: Scene {
                name: "lighting-test".into(),
                sky,
                exposure: 1.0,
                ..Default::default()
            },
        }
    }

    /// A parallelogram `center +- u +- v`, front face `u x v`, of diffuse `albedo`.
    fn quad(&mut self, center: Vec3, u: Vec3, v: Vec3, albedo: f32) -> &mut Self {
        let n = u.cross(v).normalize();
        self.scene.materials.push(Material {
            base_color: Vec3::splat(albedo).extend(1.0),
            metallic: 0.0,
            roughness: 1.0,
            ..Default::default()
        });
        self.scene.meshes.push(Mesh {
            name: String::new(),
            primitives: vec![Primitive {
                positions: vec![
                    center - u - v,
                    center + u - v,
                    center + u + v,
                    center - u + v,
                ],
                normals: vec![n; 4],
                uvs: vec![Vec2::ZERO; 4],
                indices: vec![0, 1, 2, 0, 2, 3],
                material: self.scene.materials.len() - 1,
            }],
        });
        self.scene.nodes.push(Node {
            mesh: Some(self.scene.meshes.len() - 1),
            ..Default::default()
        });
        self
    }

    fn directional(&mut self, intensity: f32, direction: Vec3) -> &mut Self {
        self.scene.lights.push(Light {
            name: String::new(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity,
            range: None,
        });
        self.scene.nodes.push(Node {
            rotation: Quat::from_rotation_arc(Vec3::NEG_Z, direction.normalize()),
            light: Some(self.scene.lights.len() - 1),
            ..Default::default()
        });
        self
    }
}

/// A cache filled on the CPU, uploaded, with its lighting technique and the scene on the GPU.
struct LitCache {
    cpu: CpuCache,
    buffers: CacheBuffers,
    gpu_scene: GpuScene,
    lighting: CacheLighting,
    timer: GpuTimer,
    bricks: Vec<LitBrick>,
    frames: u32,
}

impl LitCache {
    fn new(ctx: &GpuContext, config: &CacheConfig, scene: &Scene, frame: &SceneFrame) -> Self {
        let cpu = CpuCache::build(config, scene, frame, frame.camera.position).unwrap();
        let buffers = cpu.upload(ctx);
        let gpu_scene = GpuScene::upload(ctx, scene, frame).unwrap();
        let lighting = CacheLighting::new(
            ctx,
            &ShaderLibrary::new(),
            config,
            &CacheBuffers::bind_group_layout(ctx),
        )
        .unwrap();
        let bricks = cpu
            .bricks
            .iter()
            .map(|b| LitBrick {
                level: b.level,
                brick: b.brick,
                brick_id: b.id,
            })
            .collect();
        Self {
            cpu,
            buffers,
            gpu_scene,
            lighting,
            timer: GpuTimer::new(ctx, "cache.lighting.test", 4),
            bricks,
            frames: 0,
        }
    }

    /// One lighting frame: every brick is new on the first, resident afterwards.
    fn frame(&mut self, ctx: &GpuContext, sky: &Sky) -> (ScheduleCounts, PassTimings) {
        let mut encoder = ctx.create_encoder("cache.lighting.test");
        let new: &[LitBrick] = if self.frames == 0 { &self.bricks } else { &[] };
        let inputs = LightingInputs {
            sky,
            scene: &self.gpu_scene,
            bvh: &self.gpu_scene.bvh,
            cache_bind_group: &self.buffers.bind_group,
            new_bricks: new,
            resident: &self.bricks,
        };
        let counts = self
            .lighting
            .record(ctx, &mut self.timer, &mut encoder, &inputs);
        self.frames += 1;
        (counts, self.timer.finish(ctx, encoder))
    }

    /// `(direct, indirect)` irradiance per voxel face, unpacked.
    fn read_faces(&self, ctx: &GpuContext) -> (Vec<Vec3>, Vec<Vec3>) {
        let direct: Vec<u32> = ctx.read_buffer(&self.buffers.direct);
        let indirect: Vec<u32> = ctx.read_buffer(&self.buffers.indirect);
        (
            direct.into_iter().map(unpack_rgb9e5).collect(),
            indirect.into_iter().map(unpack_rgb9e5).collect(),
        )
    }
}

/// One visible face of an occupied voxel of the CPU cache.
#[derive(Clone, Copy, Debug)]
struct Face {
    level: u32,
    /// World voxel coordinate.
    voxel: IVec3,
    center: Vec3,
    size: f32,
    normal: Vec3,
    face: u32,
    slot: usize,
}

impl Face {
    /// The lighting passes' normal of this face: the voxel normal flipped towards the face.
    fn face_normal(&self) -> Vec3 {
        if self.normal.dot(FACE_DIRECTIONS[self.face as usize]) < -1e-3 {
            -self.normal
        } else {
            self.normal
        }
    }

    /// The point just outside the face's center (as `gi::cache::lighting::face_point`).
    fn point(&self) -> Vec3 {
        let margin = (1e-3 * self.size).max(1e-4 * (1.0 + self.center.abs().max_element()));
        self.center + FACE_DIRECTIONS[self.face as usize] * (0.5 * self.size + margin)
    }
}

/// Every visible face (the neighbouring voxel of the same level is empty) of the cache.
fn visible_faces(cpu: &CpuCache) -> Vec<Face> {
    let mut faces = Vec::new();
    for b in &cpu.bricks {
        let mask = cpu.structure.brick_mask(b.id);
        let size = cpu.config.voxel_size_at(b.level);
        for bit in 0..64 {
            if mask & (1u64 << bit) == 0 {
                continue;
            }
            let voxel = b.brick * 4 + mask_cell(bit).as_ivec3();
            let surface = cpu.voxels[voxel_index(b.id, bit) as usize];
            for face in 0..6u32 {
                let neighbour = voxel + FACE_DIRECTIONS[face as usize].as_ivec3();
                if cpu.voxel_at(b.level, neighbour).is_some() {
                    continue;
                }
                faces.push(Face {
                    level: b.level,
                    voxel,
                    center: (voxel.as_vec3() + 0.5) * size,
                    size,
                    normal: unpack_unit_vector(surface.normal),
                    face,
                    slot: face_slot(b.id, bit, face) as usize,
                });
            }
        }
    }
    faces
}

fn small_config() -> CacheConfig {
    CacheConfig {
        levels: 1,
        level_bricks: [8, 8, 8],
        pool_bricks: 512,
        near_levels: 1,
        ..Default::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Direct injection.
// ---------------------------------------------------------------------------------------------

#[test]
fn direct_injection_matches_the_analytic_irradiance_and_shadows() {
    let Some(ctx) = GpuContext::new_or_skip("direct_injection_matches_the_analytic_irradiance")
    else {
        return;
    };
    // A floor under a directional light (no zero direction component: see
    // `Reference::irradiance`'s test) with a black roof that shadows part of it.
    let intensity = 3.0;
    let light_dir = Vec3::new(0.3, -1.0, 0.5).normalize();
    let mut builder = SceneBuilder::new(Sky::default());
    builder
        .quad(
            Vec3::new(0.0, 0.03, 0.0),
            Vec3::X * 0.9,
            Vec3::NEG_Z * 0.9,
            0.5,
        )
        .quad(
            Vec3::new(0.3, 0.5, 0.0),
            Vec3::X * 0.2,
            Vec3::NEG_Z * 0.2,
            0.0,
        )
        .directional(intensity, light_dir);
    let scene = builder.scene.clone();
    let mut frame = scene.evaluate(0.0, None);
    frame.camera.position = Vec3::new(0.0, 0.1, 0.0);
    let mut lit = LitCache::new(&ctx, &small_config(), &scene, &frame);
    let (counts, timings) = lit.frame(&ctx, &scene.sky);
    println!("{counts:?}\n{timings}");
    let (direct, _) = lit.read_faces(&ctx);

    let bvh = SceneBvh::build(&frame.triangles);
    let wi = -light_dir;
    let (mut lit_faces, mut shadowed, mut below) = (0, 0, 0);
    let mut worst = 0.0f32;
    for f in visible_faces(&lit.cpu) {
        let n_f = f.face_normal();
        let cos = wi.dot(n_f);
        let occluded = bvh.occluded(&frame.triangles, f.point(), wi, 0.0, f32::INFINITY);
        let expected = if cos <= 0.0 || occluded {
            0.0
        } else {
            intensity * cos
        };
        let got = direct[f.slot];
        // RGB9E5 keeps 9 mantissa bits of the largest channel: rounding error <= 2^-9 of it.
        let error = (got - Vec3::splat(expected)).abs().max_element();
        worst = worst.max(error / expected.max(1e-3));
        assert!(
            error <= expected * 2f32.powi(-9) + 1e-6,
            "face {} of voxel {} (level {}): {got} vs {expected}",
            f.face,
            f.voxel,
            f.level
        );
        if f.normal.y > 0.99 && f.face == 2 {
            if expected > 0.0 {
                lit_faces += 1;
            } else {
                shadowed += 1;
            }
        }
        if f.normal.y > 0.99 && f.face == 3 {
            below += 1;
        }
    }
    println!(
        "floor top faces lit {lit_faces}, in the roof's shadow {shadowed}, bottom faces {below} \
         (all 0); worst relative error of lit faces {worst:.2e}; E = I cos(theta) = {:.4}",
        intensity * wi.y
    );
    assert!(lit_faces > 500 && shadowed > 20 && below > 500);
}
