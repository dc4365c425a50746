//! The mobile tier (`mobile`): the surfel brick radiance cache (gi-cache), a world-space probe
//! volume and deferred screen probes with a temporal filter, after HSGI's mobile solution
//! (GDC 2023) and SmartGI's screen-probe economy (SIGGRAPH 2024).

mod config;
mod screen;
mod volume;

pub use config::{
    MobileConfig, PROBE_TEXELS, ScreenConfig, ScreenProbeMode, VolumeConfig, VolumeConfigError,
};
pub use screen::{GpuScreenProbe, ScreenUniforms};
pub use volume::{ProbeSample, ProbeVolume, VolumeError, VolumeInputs, VolumeOutputs};

use gi_cache::lighting::GpuSky;
use gi_cache::{CacheLighting, RadianceCache, binning::dynamic_triangles};
use gi_gpu::gbuffer::GBuffer;
use gi_gpu::{GpuCamera, GpuContext, GpuTimer, Recorder, ShaderLibrary, Technique, wgpu};
use gi_image::Image;
use gi_scene::SceneFrame;
use glam::Vec3;

use crate::output::GpuOutput;
use crate::realtime::record_gbuffer_and_cache;
use crate::requirements::{FrameCost, Requirements, image_bytes};
use crate::scene_state::{Followed, SceneState, check_frame_settings};
use crate::tier::{FrameInput, TierError, TierKind, TierSettings};
use crate::tracer::{Accumulation, DirectInputs, PathPipelines};
use screen::{
    ProbeStep, ScreenLayout, ScreenPipelines, ScreenProbes, ScreenSources, ScreenStep,
    screen_uniforms,
};

/// What the mobile tier needs of an adapter at `settings`' resolution. The screen-probe
/// passes' layouts (`mobile/screen.rs`): 20 storage buffers of their own, the probe volume's 3 and the
/// brick cache's 7; four groups (the cache's is group 2, the textures group 3); the largest
/// workgroups (the cache's passes, the probe volume's, the 1D screen passes) run 64
/// invocations in x.
pub fn requirements(settings: &TierSettings) -> Requirements {
    Requirements::compute(30, image_bytes(settings))
}

/// The mobile tier's measured cost per frame on an H100, for [`crate::select`].
pub const H100_COST: FrameCost = FrameCost {
    kind: TierKind::Mobile,
    points: &[(2.0736, 2.61)],
    source: "benchmarks/RESULTS-history.md, benchmark suite, `gi-bench mobile --scenes dynamic \
             --size 1920x1080 --frames 64`: GI 1.589 + gbuffer/primary 0.334 + direct 0.688 ms",
};

/// Most timed passes in one frame (G-buffer, the cache's passes, the mobile passes, direct).
const TIMER_SCOPES: u32 = 40;

/// GPU memory of the mobile tier by what it scales with.
pub type MobileMemory = crate::realtime::GiMemory;

/// One frame's GI and what identifies its pixels, one entry per pixel in row-major order.
#[derive(Clone, Debug)]
pub struct MobileFrameData {
    /// The GI term: linear radiance the tier added to the direct light (diffuse albedo times
    /// the gathered irradiance over pi, plus the approximate specular part).
    pub gi: Image,
    /// The gathered irradiance (before albedo) of the half-resolution sample nearest each pixel.
    pub irradiance: Image,
    /// Frames of temporal history behind that sample's irradiance (1: this frame only; 0: sky).
    pub history_age: Vec<u8>,
    /// How this frame's screen probe slots were filled.
    pub probes: ProbeCounts,
    /// Pixels showing a node moved by an animation (the lite G-buffer's mask bit).
    pub dynamic: Vec<bool>,
    /// `gbuffer.motion`: previous pixel position minus this pixel's center, in pixels.
    pub motion: Vec<[f32; 2]>,
    /// `gbuffer.depth`: distance along the pixel's unit ray, `+inf` for sky.
    pub depth: Vec<f32>,
}

/// How the screen probe slots of a frame were filled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ProbeCounts {
    /// Regular probes placed and traced this frame.
    pub fresh: u32,
    /// Regular probes carried over from the previous frame (SmartGI mode).
    pub reprojected: u32,
    /// Extra probes of tiles the previous gather marked.
    pub extra: u32,
    /// Regular slots left empty: sky tiles, and SmartGI tiles no history probe claimed.
    pub empty: u32,
}

/// The mobile tier. See the module docs.
///
/// A frame: `gbuffer/primary` (ray-cast G-buffer), the cache update (`cache/*`: voxelization
/// of entering and moved bricks, screen injection, light injection and propagation),
/// `mobile/lite` (the lite G-buffer), `mobile/volume` (probe volume), `mobile/probe_place` and
/// `mobile/probe_trace` (screen probes), `mobile/gather` (half resolution, temporal),
/// `direct/trace` + `direct/resolve` (direct light, accumulated while the view holds still, up
/// to [`TierSettings::spp`] samples per pixel: the anti-aliasing of the direct tier), and
/// `mobile/compose` (upsample and final image). The GI's cost is the `cache/*` and `mobile/*`
/// passes.
pub struct MobileTier {
    settings: TierSettings,
    config: MobileConfig,
    ctx: GpuContext,
    shaders: ShaderLibrary,
    timer: GpuTimer,
    direct_pipelines: PathPipelines,
    screen_pipelines: ScreenPipelines,
    gbuffer: GBuffer,
    cache: RadianceCache,
    volume: ProbeVolume,
    prepared: Option<Prepared>,
    frame_index: u32,
    /// Cache updates since the last switch of the lights, sky or materials ([`LightWindow`],
    /// from [`gi_cache::CacheUpdateStats::lights_changed`]); `u32::MAX` before any, `max_age`
    /// or more once a change turned out to be a moving light.
    since_light_change: u32,
    /// Whether the last update found the lights' power changed.
    lights_were_changing: bool,
    /// The last frame's [`LightPower`]; `None` before the first.
    light_power: Option<LightPower>,
}

/// What a frame's lights give, but not where they are: each punctual light's kind, intensity
/// and range, the sky, and the materials' edit count (an emitter switched off). A change of
/// it is a switch, dimming or edit that opens the [`LightWindow`]; a light that is only turned
/// or moved keeps the probe volume and the histories (measured on an H100 at 1920x1080: with
/// the window after atrium's sun turned 30 degrees, 83% of the change was left after 4 frames
/// and 26% of its resolvable part resolved within 8, without it 73% and 55%; on Sponza 67% and
/// 50% against 58% and 62%), while a light switched off leaves the volume's old light behind
/// without it (atrium's sun off: the error floor 0.0052 without, 0.0037 with).
#[derive(Clone, Debug, PartialEq)]
struct LightPower {
    lights: Vec<(gi_scene::LightKind, glam::Vec3, Option<f32>)>,
    sky: gi_scene::Sky,
    material_revision: u64,
}

impl LightPower {
    fn of(frame: &gi_scene::SceneFrame) -> Self {
        Self {
            lights: frame
                .lights
                .iter()
                .map(|light| (light.kind, light.intensity, light.range))
                .collect(),
            sky: frame.sky,
            material_revision: frame.material_revision,
        }
    }

    /// Whether `frame`'s lights give what these do (no allocation: asked every frame).
    fn matches(&self, frame: &gi_scene::SceneFrame) -> bool {
        self.sky == frame.sky
            && self.material_revision == frame.material_revision
            && self.lights.len() == frame.lights.len()
            && self
                .lights
                .iter()
                .zip(&frame.lights)
                .all(|(&(kind, intensity, range), light)| {
                    (kind, intensity, range) == (light.kind, light.intensity, light.range)
                })
    }
}

/// What the mobile tier does after its cache found the lights, sky or materials changed.
///
/// After a *switch* (a change of the lights' power after stillness that stops there: a light
/// switched or dimmed, a lamp's material edited, the sky changed; see [`LightPower`]), the cache
/// follows with a short accumulation for its `max_age` updates
/// (`CHANGED_MAX_AGE`), but the probe volume, which takes one ray per probe a frame, holds the
/// old light for hundreds of frames. So the gather reads the cache's surfels where it would read
/// the volume:
/// - in the update of the change (`changed`), which cannot yet tell a switch from a light that
///   starts to move, with the histories as they are;
/// - once the next update finds the lights as they were, for the rest of the cache's `max_age`
///   updates (`open`), keeping no more history than the cache does; and the volume restarts
///   its faces' means.
///
/// A light that keeps *moving* is no switch: its second changed update ends this, and the
/// volume does not restart. On `dynamic`, whose light starts circling the room, the flicker of
/// still pixels (64x48, lavapipe) was 1.89% before any of this, 10.1% when every update of a
/// moving light read the cache with 4-frame histories, 3.8% with only its first update so, and
/// is 2.4% so; capping the histories in the update of a change also showed atrium's turned sun
/// sooner (56% left after 4 frames against 63%). The measured change (`cache_surface_change`)
/// follows a moving light where its light changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct LightWindow {
    /// The update of a change after stillness, which may be a switch or a light that starts
    /// to move: the gather reads the cache instead of the volume, with the histories as they
    /// are.
    changed: bool,
    /// The gather reads the cache instead of the volume, with short histories.
    open: bool,
    /// The volume restarts its faces' running means this frame.
    restart_volume: bool,
}

impl LightWindow {
    /// No window: the volume and the histories as they are.
    const CLOSED: Self = Self {
        changed: false,
        open: false,
        restart_volume: false,
    };

    /// Advances the state (`were_changing`: the last update found the lights changed; `since`:
    /// updates since the switch, `u32::MAX` before any) by an update that found them
    /// `changed`, for a cache of `max_age`.
    fn follow(changed: bool, were_changing: &mut bool, since: &mut u32, max_age: u32) -> Self {
        let mut restart_volume = false;
        *since = match (changed, *were_changing) {
            // A change after stillness: maybe a switch.
            (true, false) => 0,
            // Changed again right after: a moving light, no switch.
            (true, true) if *since < max_age => max_age,
            // The change stopped after one update: a switch, and the volume's old light goes.
            (false, true) if *since == 0 => {
                restart_volume = true;
                1
            }
            _ => since.saturating_add(1),
        };
        *were_changing = changed;
        Self {
            changed: *since == 0,
            open: (1..max_age).contains(since),
            restart_volume,
        }
    }
}

/// What the tier uploaded for its scene.
struct Prepared {
    state: SceneState,
    screen: ScreenProbes,
    dynamic_triangles: wgpu::Buffer,
}

impl MobileTier {
    /// A mobile tier on `ctx`. Fails when the configuration or the image size is unusable or
    /// the shaders do not compile on the device.
    pub fn new(
        settings: TierSettings,
        config: MobileConfig,
        ctx: GpuContext,
    ) -> Result<Self, TierError> {
        let unavailable = |reason: String| TierError::Unavailable {
            tier: "mobile",
            reason,
        };
        check_frame_settings(TierKind::Mobile, &settings, &requirements(&settings), &ctx)?;
        config.validate().map_err(unavailable)?;
        let shaders = ShaderLibrary::new();
        let gpu = |e: gi_gpu::GpuError| unavailable(e.to_string());
        let direct_pipelines = PathPipelines::real_time_direct(&ctx).map_err(gpu)?;
        let gbuffer = GBuffer::new(&ctx, &shaders, settings.width, settings.height).map_err(gpu)?;
        let mut cache =
            RadianceCache::new(&ctx, &config.cache).map_err(|e| unavailable(e.to_string()))?;
        CacheLighting::attach(&ctx, &shaders, &mut cache).map_err(gpu)?;
        let volume = ProbeVolume::new(&ctx, &shaders, &config.volume)
            .map_err(|e| unavailable(e.to_string()))?;
        let screen_pipelines =
            ScreenPipelines::new(&ctx, &shaders, volume.bind_group_layout()).map_err(gpu)?;
        let timer = GpuTimer::new(&ctx, "mobile", TIMER_SCOPES);
        Ok(Self {
            settings,
            config,
            ctx,
            shaders,
            timer,
            direct_pipelines,
            screen_pipelines,
            gbuffer,
            cache,
            volume,
            prepared: None,
            frame_index: 0,
            since_light_change: u32::MAX,
            lights_were_changing: false,
            light_power: None,
        })
    }

    /// The probe volume.
    pub fn volume(&self) -> &ProbeVolume {
        &self.volume
    }

    /// The last frame's GI term and the G-buffer data needed to compare it across frames,
    /// read back from the GPU (stalls); `None` before the first frame. For tests and metrics.
    pub fn frame_data(&self) -> Option<MobileFrameData> {
        let prepared = self.prepared.as_ref()?;
        let ctx = &self.ctx;
        let (width, height) = (self.settings.width, self.settings.height);
        let gbuffer = self.gbuffer.read(ctx);
        let output: Vec<[f32; 4]> = ctx.read_buffer(&prepared.screen.output);
        let direct: Vec<[f32; 4]> = ctx.read_buffer(&prepared.state.direct.mean);
        let lite: Vec<u32> = ctx.read_buffer(&prepared.screen.lite);
        let history: Vec<[u32; 2]> = ctx.read_buffer(&prepared.screen.frames.current().history);
        let half = prepared.screen.layout.half;
        let slots: Vec<GpuScreenProbe> = ctx.read_buffer(&prepared.screen.frames.current().probes);
        let mut probes = ProbeCounts::default();
        for (slot, probe) in slots.iter().enumerate() {
            let valid = probe.depth > 0.0;
            match (slot as u32 % screen::SLOTS_PER_TILE, valid) {
                (0, true) if probe.flags & 2 != 0 => probes.reprojected += 1,
                (0, true) => probes.fresh += 1,
                (0, false) => probes.empty += 1,
                (_, true) => probes.extra += 1,
                (_, false) => {}
            }
        }
        let half_index =
            |x: u32, y: u32| ((y / 2).min(half.1 - 1) * half.0 + (x / 2).min(half.0 - 1)) as usize;
        let gi = output
            .iter()
            .zip(&direct)
            .map(|(o, d)| Vec3::from_slice(o) - Vec3::from_slice(d))
            .collect();
        let pixels: Vec<(u32, u32)> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .collect();
        let irradiance = pixels
            .iter()
            .map(|&(x, y)| gi_cache::packing::unpack_rgb9e5(history[half_index(x, y)][0]))
            .collect();
        let history_age = pixels
            .iter()
            .map(|&(x, y)| (history[half_index(x, y)][1] & 0xff) as u8)
            .collect();
        let image = |pixels| Image {
            width,
            height,
            pixels,
        };
        Some(MobileFrameData {
            gi: image(gi),
            irradiance: image(irradiance),
            history_age,
            probes,
            dynamic: lite.iter().map(|bits| bits & (1 << 23) != 0).collect(),
            motion: gbuffer.motion,
            depth: gbuffer.depth,
        })
    }

    /// Makes the GPU state match `input` ([`SceneState`]): the scene is uploaded once and
    /// follows animation, light edits and camera moves.
    fn prepare(&mut self, input: &FrameInput) -> Result<(), TierError> {
        let size = (self.settings.width, self.settings.height);
        let seed = self.settings.seed;
        if let Some(prepared) = self.prepared.as_mut()
            && prepared.state.holds(input.frame)
        {
            let followed = prepared.state.follow(
                &self.ctx,
                "mobile",
                input,
                &self.direct_pipelines,
                size,
                seed,
            )?;
            if followed == Followed::Replaced {
                // The screen bind groups name the direct image: make them again (history is
                // lost).
                let mut prepared = self.prepared.take().expect("checked above");
                let screen =
                    self.screen_buffers(&prepared.state.direct, &prepared.dynamic_triangles);
                std::mem::replace(&mut prepared.screen, screen).release(&self.ctx);
                self.prepared = Some(prepared);
            }
            return Ok(());
        }
        if let Some(old) = self.prepared.take() {
            old.release(&self.ctx);
        }
        let state = SceneState::upload(
            &self.ctx,
            "mobile",
            input,
            &self.direct_pipelines,
            size,
            seed,
            &self.settings.textures,
        )?;
        self.gbuffer.prepare_layers(&self.ctx, &state.scene);
        let dynamic_triangles = dynamic_triangle_bits(&self.ctx, input.scene, input.frame);
        let screen = self.screen_buffers(&state.direct, &dynamic_triangles);
        self.prepared = Some(Prepared {
            state,
            screen,
            dynamic_triangles,
        });
        Ok(())
    }

    fn screen_buffers(
        &self,
        direct: &Accumulation,
        dynamic_triangles: &wgpu::Buffer,
    ) -> ScreenProbes {
        let layout = ScreenLayout::new(
            self.settings.width,
            self.settings.height,
            self.config.screen.tile_px,
        );
        ScreenProbes::new(
            &self.ctx,
            &self.screen_pipelines,
            layout,
            self.config.screen.mode,
            &ScreenSources {
                gbuffer: self.gbuffer.outputs(),
                dynamic_triangles,
                direct_mean: &direct.mean,
            },
        )
    }
}

impl Prepared {
    fn release(self, ctx: &GpuContext) {
        self.screen.release(ctx);
        ctx.release_buffer(&self.dynamic_triangles);
        self.state.release(ctx);
    }
}

/// One bit per frame triangle, set when the triangle's node is moved by an animation
/// (`mobile.dynamic_triangles`).
fn dynamic_triangle_bits(
    ctx: &GpuContext,
    scene: &gi_scene::Scene,
    frame: &SceneFrame,
) -> wgpu::Buffer {
    let mut bits = vec![0u32; frame.triangles.len().div_ceil(32).max(1)];
    for (index, dynamic) in dynamic_triangles(scene, frame).into_iter().enumerate() {
        if dynamic {
            bits[index / 32] |= 1 << (index % 32);
        }
    }
    ctx.create_buffer_init(
        "mobile.dynamic_triangles",
        bytemuck::cast_slice(&bits),
        wgpu::BufferUsages::STORAGE,
    )
}

crate::realtime::real_time_tier!(
    MobileTier,
    TierKind::Mobile,
    MobileConfig,
    &["mobile.volume."]
);

impl MobileTier {
    /// Where the last frame's image and direct light lie; `None` before the first frame.
    fn output(&self) -> Option<GpuOutput<'_>> {
        let prepared = self.prepared.as_ref()?;
        Some(GpuOutput {
            ctx: &self.ctx,
            image: &prepared.screen.output,
            direct: Some(&prepared.state.direct.mean),
            size: (self.settings.width, self.settings.height),
        })
    }

    /// Records and submits the frame but for its last encoder, which it returns for the
    /// caller to end the timer's frame with (waiting for it or not).
    fn record_frame(&mut self, input: &FrameInput) -> Result<wgpu::CommandEncoder, TierError> {
        let frame = input.frame;
        self.prepare(input)?;
        let size = (self.settings.width, self.settings.height);
        let MobileTier {
            ctx,
            timer,
            gbuffer,
            cache,
            volume,
            prepared,
            config,
            settings,
            frame_index,
            since_light_change,
            lights_were_changing,
            light_power,
            ..
        } = self;
        let Prepared { state, screen, .. } = prepared.as_mut().expect("prepared above");
        let scene = &state.scene;
        let blend_layer = gbuffer.has_blend_layer();
        let mut rec = Recorder::new(ctx, timer, "mobile/frame");

        let (_, cache) = record_gbuffer_and_cache(&mut rec, gbuffer, cache, input, state);
        // A cache fill (a first view, a jump) lights through missing walls: history gathered
        // from it must not be kept.
        if cache.stats.filling {
            screen.reset_history();
        }
        let cache_buffers = cache.buffers;
        let mut uniforms = screen_uniforms(
            &config.screen,
            screen.layout,
            GpuCamera::new(&frame.camera, size),
            GpuCamera::new(&state.previous.camera, size),
            GpuSky::new(&frame.sky),
            *frame_index,
            settings.seed,
        );
        if blend_layer {
            uniforms.flags |= screen::FLAG_BLEND_LAYER;
        }
        uniforms.change_gain = config.cache.change_gain;
        // A switch of the lights or materials: the gather leaves the probe volume, which still
        // holds the old light, for the cache's while it converges (`LightWindow`).
        // The cache found the lights changed; the window follows changes of their power only.
        let power_changed = match light_power {
            Some(last) => !last.matches(frame),
            None => false,
        };
        if power_changed || light_power.is_none() {
            *light_power = Some(LightPower::of(frame));
        }
        let window = if config.screen.light_window {
            LightWindow::follow(
                cache.stats.lights_changed && power_changed,
                lights_were_changing,
                since_light_change,
                config.cache.max_age,
            )
        } else {
            LightWindow::CLOSED
        };
        if window.open {
            uniforms.flags |= screen::FLAG_VOLUME_STALE;
            uniforms.max_age = uniforms.max_age.min(gi_cache::lighting::CHANGED_MAX_AGE);
        } else if window.changed {
            // No history cap: this may be a light that starts to move.
            uniforms.flags |= screen::FLAG_VOLUME_STALE;
        }
        screen.begin_frame(ctx, uniforms);
        let cache = &cache_buffers.bind_group;
        screen.record(
            &mut rec,
            &ProbeStep {
                step: ScreenStep::Lite,
                volume: volume.bind_group(),
                cache,
            },
        );
        let volume = volume.record(
            &mut rec,
            &VolumeInputs {
                cache: cache_buffers,
                camera_position: frame.camera.position,
                sky: &frame.sky,
                frame_index: *frame_index,
                restart: window.restart_volume,
            },
        );
        for step in [ScreenStep::Probes, ScreenStep::Gather] {
            let inputs = ProbeStep {
                step,
                volume: volume.bind_group,
                cache,
            };
            screen.record(&mut rec, &inputs);
        }
        rec.submit("mobile/compose");

        let samples = u32::from(state.direct.samples < settings.spp);
        state
            .direct
            .record(&mut rec, &DirectInputs { scene, samples });
        screen.record(
            &mut rec,
            &ProbeStep {
                step: ScreenStep::Compose,
                volume: volume.bind_group,
                cache,
            },
        );

        state.finish_frame(frame);
        *frame_index = frame_index.wrapping_add(1);
        if let Some(progress) = input.progress {
            progress(state.direct.samples);
        }
        Ok(rec.into_encoder())
    }
}

#[cfg(test)]
mod tests {
    use super::{LightPower, LightWindow};

    #[test]
    fn a_turned_or_moved_light_keeps_its_power_and_a_switch_or_edit_does_not() {
        let mut scene = gi_scene::Scene::default();
        scene.lights.push(gi_scene::Light {
            name: "sun".into(),
            kind: gi_scene::LightKind::Directional,
            color: glam::Vec3::ONE,
            intensity: 3.0,
            range: None,
        });
        scene.nodes.push(gi_scene::Node {
            light: Some(0),
            ..gi_scene::Node::default()
        });
        let power = |scene: &gi_scene::Scene| LightPower::of(&scene.evaluate(0.0, None));
        let before = power(&scene);
        assert_eq!(before.lights.len(), 1);
        let mut turned = scene.clone();
        turned.nodes[0].rotation = glam::Quat::from_rotation_y(0.5);
        turned.nodes[0].translation = glam::Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(power(&turned), before, "turned and moved");
        assert!(before.matches(&turned.evaluate(0.0, None)));
        let mut dimmed = scene.clone();
        dimmed.lights[0].intensity = 0.0;
        assert_ne!(power(&dimmed), before, "switched off");
        let mut edited = scene.evaluate(0.0, None);
        edited.material_revision += 1;
        assert_ne!(LightPower::of(&edited), before, "a material edited");
        assert!(!before.matches(&edited));
        assert!(!before.matches(&dimmed.evaluate(0.0, None)));
    }

    /// The windows of consecutive updates that found the lights changed or not.
    fn windows(changes: &[bool], max_age: u32) -> Vec<LightWindow> {
        let (mut were_changing, mut since) = (false, u32::MAX);
        changes
            .iter()
            .map(|&changed| LightWindow::follow(changed, &mut were_changing, &mut since, max_age))
            .collect()
    }

    #[test]
    fn a_switch_opens_the_window_for_max_age_updates_and_restarts_the_volume_once() {
        let mut changes = vec![false, false, true];
        changes.extend([false; 6]);
        let seen = windows(&changes, 4);
        let changed: Vec<usize> = (0..seen.len()).filter(|&i| seen[i].changed).collect();
        assert_eq!(changed, [2], "the update of the change");
        let open: Vec<usize> = (0..seen.len()).filter(|&i| seen[i].open).collect();
        assert_eq!(
            open,
            [3, 4, 5],
            "the updates after it, up to max_age after the change"
        );
        let restarts: Vec<usize> = (0..seen.len())
            .filter(|&i| seen[i].restart_volume)
            .collect();
        assert_eq!(
            restarts,
            [3],
            "the update after the switch restarts the volume"
        );
    }

    #[test]
    fn a_moving_light_closes_the_window_and_leaves_the_volume() {
        let mut changes = vec![false, true];
        changes.extend([true; 40]);
        changes.extend([false; 3]);
        let seen = windows(&changes, 32);
        assert!(seen[1].changed, "a change after stillness may be a switch");
        assert!(
            seen.iter().all(|w| !w.open && !w.restart_volume),
            "{seen:?}"
        );
        assert!(seen[2..].iter().all(|w| !w.changed), "{seen:?}");
        // Stillness again, then a switch: the window opens as after any switch.
        let mut again = changes.clone();
        again.extend([true, false]);
        let seen = windows(&again, 32);
        let last = seen.len() - 1;
        assert!(seen[last - 1].changed && seen[last].open && seen[last].restart_volume);
    }
}
