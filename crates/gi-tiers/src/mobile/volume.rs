//! The mobile tier's world-space probe volume (HSGI, GDC 2023, "Mobile Solution / Probe
//! Volume", sampled as DDGI does): a clipmap of [`VolumeConfig::levels`] levels of probes around
//! the camera, each probe an ambient cube (six face irradiances with their sample counts) plus
//! depth moments per face for Chebyshev visibility and a relocation offset.
//!
//! - Layout, sampling and the group-1 bindings: `shaders/mobile/volume/shared.wgsl`
//!   (`gi::mobile::volume`, whose `volume_irradiance(p, n)` the gather passes call).
//! - Update, timer scope `mobile/volume`: `shaders/mobile/volume/update.wgsl`, two dispatches in
//!   one compute pass. `classify_probes` (one invocation per slot) resets probes that entered
//!   the clipmap, keeps active only those with an occupied cache brick within one spacing (read
//!   from the cache's group masks) and lists them; `trace_probes` (indirect, `CACHE_LANES` invocations
//!   per listed probe) relocates flagged probes and traces [`VolumeConfig::rays_per_probe`] rays
//!   through the cache, each updating one random face.
//!
//! Slots are toroidal (world probe coordinate modulo the window's size) and remember the
//! coordinate they hold, so a camera move resets only the probes that enter. Memory of the
//! default configuration (2 levels of 24 x 12 x 24 probes): 192 bytes per probe (48 of state,
//! 96 of faces, 48 of moments) plus a 4-byte list entry, 2.6 MiB in all.

use bytemuck::{Pod, Zeroable};
use gi_cache::CacheBuffers;
use gi_cache::lighting::GpuSky;
use gi_cache::query::GpuIrradianceQuery;
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::{GpuContext, GpuError, Recorder, ShaderLibrary, Technique, wgpu};
use glam::{IVec3, Vec3, Vec4};

use super::config::{VolumeConfig, VolumeConfigError};

/// Bind group of the volume in the update passes and in the gather passes that sample it.
pub const VOLUME_BIND_GROUP: u32 = 1;

/// Invocations per workgroup of every entry point (`WORKGROUP_SIZE` in the shader).
const WORKGROUP_SIZE: u32 = 64;

/// Seed of the probes' random sequences (each probe's sequence is indexed by the frame).
const RAY_SEED: u32 = 0x766f_6c75;

/// Clipmap levels the uniforms have room for (`VOLUME_MAX_LEVELS`).
const MAX_LEVELS: usize = VolumeConfig::MAX_LEVELS as usize;

/// `ProbeState::flags` bits (`PROBE_*` in `gi::mobile::volume`).
const PROBE_INITIALIZED: u32 = 1;
const PROBE_ACTIVE: u32 = 2;
const PROBE_BURIED: u32 = 8;

/// One level's window (`gi::mobile::volume::VolumeLevel`, 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVolumeLevel {
    /// World probe coordinate of the window's lowest corner.
    pub origin: [i32; 3],
    /// Distance between the level's probes, meters.
    pub spacing_m: f32,
}

/// The volume's uniforms (`gi::mobile::volume::VolumeUniforms`, 96 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVolumeUniforms {
    pub levels: [GpuVolumeLevel; MAX_LEVELS],
    /// Probes per level along x, y, z.
    pub probes: [u32; 3],
    pub level_count: u32,
    pub probes_per_level: u32,
    /// [`VolumeConfig::max_age`].
    pub max_age: u32,
    pub pad_a: u32,
    pub pad_b: u32,
}

/// One slot's probe (`gi::mobile::volume::ProbeState`, 48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuProbeState {
    /// World probe coordinate of the probe the slot holds.
    pub coord: [i32; 3],
    /// `PROBE_*` bits: initialized, active, relocation pending, buried.
    pub flags: u32,
    /// Relocation offset from the grid point, meters.
    pub offset: [f32; 3],
    /// Rays traced since the probe entered the window.
    pub age: u32,
    /// Occupancy around the probe its relocation was computed for.
    pub signature: u32,
    /// Sample counts of the six depth bins, 5 bits each.
    pub moment_counts: u32,
    pub pad_a: u32,
    pub pad_b: u32,
}

/// Uniforms of the update passes (`UpdateUniforms` in `mobile/volume/update.wgsl`, 96 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuUpdateUniforms {
    /// What rays leaving the cache see.
    pub sky: GpuSky,
    /// Sample index of every probe's random sequence.
    pub frame_index: u32,
    pub rays_per_probe: u32,
    pub seed: u32,
    /// Slots of all levels.
    pub slot_count: u32,
    /// 1 when every face's samples restart ([`VolumeInputs::restart`]).
    pub restart: u32,
    pub pad_a: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

/// What the volume cannot be made with.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    #[error(transparent)]
    Config(#[from] VolumeConfigError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// One probe slot as [`ProbeVolume::read_probes`] reads it back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeSample {
    /// Clipmap level of the slot.
    pub level: u32,
    /// World probe coordinate the slot holds (its grid point is `coord * spacing`).
    pub coord: IVec3,
    /// World position after relocation.
    pub position: Vec3,
    /// The slot holds a probe of the current windows.
    pub initialized: bool,
    /// The cache has geometry within about one spacing: the probe is updated.
    pub active: bool,
    /// No candidate spot is free of geometry: the probe is neither updated nor sampled.
    pub buried: bool,
    /// Rays traced since the probe entered the window.
    pub age: u32,
    /// Irradiance of the faces +x, -x, +y, -y, +z, -z.
    pub irradiance: [Vec3; 6],
    /// Samples of each face (the temporal weight is `1 / min(samples, max_age)`).
    pub face_samples: [u32; 6],
    /// Mean depth and mean squared depth of the first hit along the bin's axis, per direction
    /// bin (rays binned by their major axis, same order), and the bins' sample counts.
    pub moments: [[f32; 2]; 6],
    pub moment_samples: [u32; 6],
}

/// The probe volume. See the module docs.
pub struct ProbeVolume {
    config: VolumeConfig,
    slot_count: u32,
    /// `mobile.volume.uniforms`: [`GpuVolumeUniforms`].
    uniforms: wgpu::Buffer,
    /// `mobile.volume.probes`: a [`GpuProbeState`] per slot.
    probes: wgpu::Buffer,
    /// `mobile.volume.faces`: 6 x vec4 per slot (irradiance, samples).
    faces: wgpu::Buffer,
    /// `mobile.volume.moments`: 6 x vec2 per slot (mean depth, mean squared depth).
    moments: wgpu::Buffer,
    /// `mobile.volume.update_uniforms`: [`GpuUpdateUniforms`].
    update_uniforms: wgpu::Buffer,
    /// `mobile.volume.active_list`: slots traced this frame.
    active_list: wgpu::Buffer,
    /// `mobile.volume.active_count`: entries of the list.
    active_count: wgpu::Buffer,
    /// `mobile.volume.dispatch_args`: workgroups of `trace_probes` (indirect).
    dispatch_args: wgpu::Buffer,
    /// `mobile.volume.dispatch_init`: `[0, 1, 1, 0]`, copied over the arguments every frame.
    dispatch_init: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    classify_group: wgpu::BindGroup,
    trace_group: wgpu::BindGroup,
    irradiance_at_layout: wgpu::BindGroupLayout,
    /// Entry point `classify_probes`.
    classify_probes: wgpu::ComputePipeline,
    /// Entry point `trace_probes`.
    trace_probes: wgpu::ComputePipeline,
    /// Entry point `irradiance_at` (tests and tools).
    irradiance_at: wgpu::ComputePipeline,
}

/// `buffer`, whole, at `binding`.
fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// A labeled bind group layout of `entries`.
fn bind_group_layout(
    ctx: &GpuContext,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    ctx.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries,
        })
}

/// What one update of the probe volume reads.
#[derive(Clone, Copy)]
pub struct VolumeInputs<'a> {
    /// The brick cache the probes' rays trace.
    pub cache: &'a CacheBuffers,
    /// Where the clipmap is centered.
    pub camera_position: Vec3,
    /// What rays that leave the cache see.
    pub sky: &'a gi_scene::Sky,
    /// Indexes every probe's random sequence.
    pub frame_index: u32,
    /// The light changed ([`gi_cache::CacheUpdateStats::lights_changed`]): every face's running
    /// mean restarts, so that its next samples replace the old light instead of joining up to
    /// `max_age` samples of it. The faces keep their values until then.
    pub restart: bool,
}

/// What one update of the probe volume produced.
pub struct VolumeOutputs<'a> {
    /// The volume's bind group (group 1 of the screen passes), over the updated probes.
    pub bind_group: &'a wgpu::BindGroup,
}

impl Technique for ProbeVolume {
    type Inputs<'i> = VolumeInputs<'i>;
    type Outputs<'o> = VolumeOutputs<'o>;

    /// Re-centers the clipmap on the camera and records the `mobile/volume` pass: probes that
    /// entered a window are reset, active probes relocated where needed and updated with
    /// [`VolumeConfig::rays_per_probe`] rays each through the cache; rays that leave the cache
    /// see the sky.
    ///
    /// The uniforms go through the queue, so record at most one update per submission.
    fn record<'o>(
        &'o mut self,
        rec: &mut Recorder<'_>,
        inputs: &VolumeInputs<'_>,
    ) -> VolumeOutputs<'o> {
        let VolumeInputs {
            cache,
            camera_position,
            sky,
            frame_index,
            restart,
        } = *inputs;
        let ctx = rec.ctx;
        let uniforms = self.uniforms_at(camera_position);
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let update = GpuUpdateUniforms {
            sky: GpuSky::new(sky),
            frame_index,
            rays_per_probe: self.config.rays_per_probe,
            seed: RAY_SEED,
            slot_count: self.slot_count,
            restart: u32::from(restart),
            ..Default::default()
        };
        ctx.queue
            .write_buffer(&self.update_uniforms, 0, bytemuck::bytes_of(&update));
        let encoder = rec.encoder();
        encoder.copy_buffer_to_buffer(&self.dispatch_init, 0, &self.dispatch_args, 0, 16);
        encoder.clear_buffer(&self.active_count, 0, None);
        rec.compute_pass("mobile/volume", |pass| {
            pass.set_pipeline(&self.classify_probes);
            pass.set_bind_group(0, &self.classify_group, &[]);
            pass.set_bind_group(VOLUME_BIND_GROUP, &self.bind_group, &[]);
            pass.set_bind_group(CacheBuffers::BIND_GROUP, &cache.bind_group, &[]);
            pass.dispatch_workgroups(self.slot_count.div_ceil(WORKGROUP_SIZE), 1, 1);
            // The classify pass's list and counts feed the trace pass; the arguments buffer is
            // not bound here (it is the indirect buffer of this dispatch).
            pass.set_pipeline(&self.trace_probes);
            pass.set_bind_group(0, &self.trace_group, &[]);
            pass.dispatch_workgroups_indirect(&self.dispatch_args, 0);
        });
        VolumeOutputs {
            bind_group: &self.bind_group,
        }
    }
}

impl ProbeVolume {
    /// Validates `config`, allocates the volume (all probes uninitialized) and builds the
    /// pipelines of `shaders/mobile/volume/`: `update.wgsl` (`classify_probes`,
    /// `trace_probes`) and `irradiance_at.wgsl`.
    pub fn new(
        ctx: &GpuContext,
        shaders: &ShaderLibrary,
        config: &VolumeConfig,
    ) -> Result<Self, VolumeError> {
        config.validate()?;
        let slots = config.slot_count();
        let faces_bytes = slots * 6 * 16;
        let available = ctx.device.limits().max_storage_buffer_binding_size;
        if faces_bytes > available {
            return Err(GpuError::LimitTooSmall {
                limit: "max_storage_buffer_binding_size",
                needed: faces_bytes,
                available,
            }
            .into());
        }
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let uniforms = ctx.create_buffer(
            "mobile.volume.uniforms",
            size_of::<GpuVolumeUniforms>() as u64,
            uniform,
        );
        let probes = ctx.create_buffer(
            "mobile.volume.probes",
            slots * size_of::<GpuProbeState>() as u64,
            storage,
        );
        let faces = ctx.create_buffer("mobile.volume.faces", faces_bytes, storage);
        let moments = ctx.create_buffer("mobile.volume.moments", slots * 6 * 8, storage);
        let update_uniforms = ctx.create_buffer(
            "mobile.volume.update_uniforms",
            size_of::<GpuUpdateUniforms>() as u64,
            uniform,
        );
        let active_list = ctx.create_buffer("mobile.volume.active_list", slots * 4, storage);
        let active_count = ctx.create_buffer("mobile.volume.active_count", 16, storage);
        let dispatch_args = ctx.create_buffer(
            "mobile.volume.dispatch_args",
            16,
            storage | wgpu::BufferUsages::INDIRECT,
        );
        let dispatch_init = ctx.create_buffer_init(
            "mobile.volume.dispatch_init",
            bytemuck::cast_slice(&[0u32, 1, 1, 0]),
            wgpu::BufferUsages::COPY_SRC,
        );

        let layout = Self::create_bind_group_layout(ctx);
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mobile.volume.bind_group"),
            layout: &layout,
            entries: &buffer_entries(0, [&uniforms, &probes, &faces, &moments]),
        });
        let classify_layout = bind_group_layout(
            ctx,
            "mobile.volume.classify_probes_group",
            &[
                uniform_entry(0),
                storage_entry(8, false),
                storage_entry(9, false),
                storage_entry(10, false),
            ],
        );
        let trace_layout = bind_group_layout(
            ctx,
            "mobile.volume.trace_probes_group",
            &[
                uniform_entry(0),
                storage_entry(8, false),
                storage_entry(10, false),
            ],
        );
        let irradiance_at_layout = bind_group_layout(
            ctx,
            "mobile.volume.irradiance_at_group",
            &[storage_entry(11, false), storage_entry(12, false)],
        );
        let classify_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mobile.volume.classify_probes_group"),
            layout: &classify_layout,
            entries: &[
                entry(0, &update_uniforms),
                entry(8, &active_list),
                entry(9, &dispatch_args),
                entry(10, &active_count),
            ],
        });
        let trace_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mobile.volume.trace_probes_group"),
            layout: &trace_layout,
            entries: &[
                entry(0, &update_uniforms),
                entry(8, &active_list),
                entry(10, &active_count),
            ],
        });

        let update = shaders.create_module(ctx, "mobile/volume/update.wgsl", &[])?;
        let irradiance_at = shaders.create_module(ctx, "mobile/volume/irradiance_at.wgsl", &[])?;
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let pipeline =
            |module: &wgpu::ShaderModule, entry_point: &str, group0: &wgpu::BindGroupLayout| {
                ctx.create_compute_pipeline_with_layouts(
                    &format!("mobile.volume.{entry_point}"),
                    module,
                    entry_point,
                    &[Some(group0), Some(&layout), Some(&cache_layout)],
                )
            };
        Ok(Self {
            classify_probes: pipeline(&update, "classify_probes", &classify_layout),
            trace_probes: pipeline(&update, "trace_probes", &trace_layout),
            irradiance_at: pipeline(&irradiance_at, "irradiance_at", &irradiance_at_layout),
            config: config.clone(),
            slot_count: slots as u32,
            uniforms,
            probes,
            faces,
            moments,
            update_uniforms,
            active_list,
            active_count,
            dispatch_args,
            dispatch_init,
            layout,
            bind_group,
            classify_group,
            trace_group,
            irradiance_at_layout,
        })
    }

    /// The layout of bind group [`VOLUME_BIND_GROUP`] as `gi::mobile::volume` declares it: a
    /// uniform at binding 0 and three read-write storage buffers at 1 to 3, compute stages.
    fn create_bind_group_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        bind_group_layout(
            ctx,
            "mobile.volume.bind_group_layout",
            &[
                uniform_entry(0),
                storage_entry(1, false),
                storage_entry(2, false),
                storage_entry(3, false),
            ],
        )
    }

    /// Layout of group 1 as the gather passes bind it.
    pub fn bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The volume's buffers, bound as `gi::mobile::volume` declares them (group 1).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    pub fn config(&self) -> &VolumeConfig {
        &self.config
    }

    /// The volume's uniforms with every level's window centered on `camera_position`: level
    /// `k`'s window starts `probes / 2` probes below the probe coordinate holding the camera.
    pub fn uniforms_at(&self, camera_position: Vec3) -> GpuVolumeUniforms {
        let dims = glam::UVec3::from(self.config.probes).as_ivec3();
        let mut levels = [GpuVolumeLevel::default(); MAX_LEVELS];
        for (level, window) in levels
            .iter_mut()
            .enumerate()
            .take(self.config.levels as usize)
        {
            let spacing_m = self.config.spacing_at(level as u32);
            let center = (camera_position / spacing_m).floor().as_ivec3();
            *window = GpuVolumeLevel {
                origin: (center - dims / 2).to_array(),
                spacing_m,
            };
        }
        GpuVolumeUniforms {
            levels,
            probes: self.config.probes,
            level_count: self.config.levels,
            probes_per_level: self.config.probes_per_level() as u32,
            max_age: self.config.max_age,
            ..Default::default()
        }
    }

    /// GPU bytes of the volume's buffers (labels `mobile.volume.*`).
    pub fn memory_bytes(&self, ctx: &GpuContext) -> u64 {
        ctx.memory().bytes_with_prefix("mobile.volume.")
    }

    /// Releases every buffer of the volume.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.uniforms,
            &self.probes,
            &self.faces,
            &self.moments,
            &self.update_uniforms,
            &self.active_list,
            &self.active_count,
            &self.dispatch_args,
            &self.dispatch_init,
        ] {
            ctx.release_buffer(buffer);
        }
    }

    /// Every slot's probe, read back (stalls the GPU; for tests and tools), in slot order:
    /// level-major, then x fastest over the toroidal positions.
    pub fn read_probes(&self, ctx: &GpuContext) -> Vec<ProbeSample> {
        let states: Vec<GpuProbeState> = ctx.read_buffer(&self.probes);
        let faces: Vec<[f32; 4]> = ctx.read_buffer(&self.faces);
        let moments: Vec<[f32; 2]> = ctx.read_buffer(&self.moments);
        let per_level = self.config.probes_per_level() as usize;
        states
            .iter()
            .enumerate()
            .map(|(slot, state)| {
                let level = (slot / per_level) as u32;
                let coord = IVec3::from(state.coord);
                let face = |f: usize| faces[slot * 6 + f];
                ProbeSample {
                    level,
                    coord,
                    position: coord.as_vec3() * self.config.spacing_at(level)
                        + Vec3::from(state.offset),
                    initialized: state.flags & PROBE_INITIALIZED != 0,
                    active: state.flags & PROBE_ACTIVE != 0,
                    buried: state.flags & PROBE_BURIED != 0,
                    age: state.age,
                    irradiance: std::array::from_fn(|f| {
                        let [r, g, b, _] = face(f);
                        Vec3::new(r, g, b)
                    }),
                    face_samples: std::array::from_fn(|f| face(f)[3] as u32),
                    moments: std::array::from_fn(|f| moments[slot * 6 + f]),
                    moment_samples: std::array::from_fn(|f| (state.moment_counts >> (5 * f)) & 31),
                }
            })
            .collect()
    }

    /// `volume_irradiance` at each `(point, unit normal)` (stalls the GPU; for tests and
    /// tools): rgb irradiance, w the weight of the probes used (0: no probe covers the point).
    pub fn irradiance_at(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        queries: &[(Vec3, Vec3)],
    ) -> Vec<Vec4> {
        if queries.is_empty() {
            return Vec::new();
        }
        let gpu_queries = GpuIrradianceQuery::batch(queries);
        let input = ctx.create_buffer_init(
            "mobile.volume.queries",
            bytemuck::cast_slice(&gpu_queries),
            wgpu::BufferUsages::STORAGE,
        );
        let output = ctx.create_buffer(
            "mobile.volume.results",
            queries.len() as u64 * 16,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let batch = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mobile.volume.irradiance_at_group"),
            layout: &self.irradiance_at_layout,
            entries: &buffer_entries(11, [&input, &output]),
        });
        let mut encoder = ctx.create_encoder("mobile.volume.irradiance_at");
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("mobile/volume_irradiance_at"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.irradiance_at);
            pass.set_bind_group(0, &batch, &[]);
            pass.set_bind_group(VOLUME_BIND_GROUP, &self.bind_group, &[]);
            pass.set_bind_group(CacheBuffers::BIND_GROUP, &cache.bind_group, &[]);
            pass.dispatch_workgroups((queries.len() as u32).div_ceil(WORKGROUP_SIZE), 1, 1);
        }
        ctx.submit_and_wait(encoder);
        let values: Vec<[f32; 4]> = ctx.read_buffer(&output);
        ctx.release_buffer(&input);
        ctx.release_buffer(&output);
        values.into_iter().map(Vec4::from).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gi_gpu::{rust_field_offsets, wgsl_struct_layout};

    /// Every struct shared with WGSL has the size and member offsets naga gives it.
    #[test]
    fn volume_structs_match_their_wgsl_layout() {
        let module = ShaderLibrary::new()
            .compose("mobile/volume/update.wgsl", &[])
            .unwrap();
        let queries = ShaderLibrary::new()
            .compose("mobile/volume/irradiance_at.wgsl", &[])
            .unwrap();
        let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
            let wgsl = wgsl_struct_layout(&module, name)
                .or_else(|| wgsl_struct_layout(&queries, name))
                .unwrap_or_else(|| panic!("{name}"));
            assert_eq!(wgsl.members, rust, "{name}");
            assert_eq!(wgsl.size as usize, size, "{name}");
        };
        check(
            "VolumeLevel",
            rust_field_offsets!(GpuVolumeLevel { origin, spacing_m }),
            size_of::<GpuVolumeLevel>(),
        );
        check(
            "VolumeUniforms",
            rust_field_offsets!(GpuVolumeUniforms {
                levels,
                probes,
                level_count,
                probes_per_level,
                max_age,
                pad_a,
                pad_b
            }),
            size_of::<GpuVolumeUniforms>(),
        );
        check(
            "ProbeState",
            rust_field_offsets!(GpuProbeState {
                coord,
                flags,
                offset,
                age,
                signature,
                moment_counts,
                pad_a,
                pad_b
            }),
            size_of::<GpuProbeState>(),
        );
        check(
            "UpdateUniforms",
            rust_field_offsets!(GpuUpdateUniforms {
                sky,
                frame_index,
                rays_per_probe,
                seed,
                slot_count,
                restart,
                pad_a,
                pad_b,
                pad_c
            }),
            size_of::<GpuUpdateUniforms>(),
        );
        check(
            "IrradianceQuery",
            rust_field_offsets!(GpuIrradianceQuery {
                position,
                pad_a,
                normal,
                pad_b
            }),
            size_of::<GpuIrradianceQuery>(),
        );
        assert_eq!(size_of::<GpuProbeState>(), 48);
        assert_eq!(size_of::<GpuVolumeUniforms>(), 96);
        // The import module composes on its own too (gather passes import it without the
        // update's imports).
        ShaderLibrary::new()
            .compose("mobile/volume/shared.wgsl", &[])
            .unwrap();
    }

    #[test]
    fn invalid_settings_name_the_field() {
        let default = VolumeConfig::default();
        default.validate().unwrap();
        let bad = [
            (
                "levels",
                VolumeConfig {
                    levels: 5,
                    ..default.clone()
                },
            ),
            (
                "probes",
                VolumeConfig {
                    probes: [1, 12, 24],
                    ..default.clone()
                },
            ),
            (
                "probes",
                VolumeConfig {
                    probes: [256, 256, 256],
                    ..default.clone()
                },
            ),
            (
                "spacing_m",
                VolumeConfig {
                    spacing_m: f32::NAN,
                    ..default.clone()
                },
            ),
            (
                "rays_per_probe",
                VolumeConfig {
                    rays_per_probe: 0,
                    ..default.clone()
                },
            ),
            (
                "max_age",
                VolumeConfig {
                    max_age: 0,
                    ..default.clone()
                },
            ),
        ];
        for (field, config) in bad {
            let err = config.validate().unwrap_err().to_string();
            assert!(err.contains(field), "{err}");
        }
    }
}
