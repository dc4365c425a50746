//! The [`Renderer`] facade: a scene, a tier and a frame counter, and the creation of the tier
//! a [`TierChoice`] asks for, trying the candidates of a [`Plan`] in order for `Auto`.

use std::any::Any;

use gi_scene::{CameraView, Evaluation, Light, Material, Scene, SceneFrame};
use glam::{Mat4, Quat, Vec3};

use gi_gpu::{GpuContext, TextureOptions, wgpu};

use crate::{
    cpu::CpuTier,
    mobile::{MobileConfig, MobileTier},
    output::OutputTextures,
    path::GpuPathTier,
    pc::{PcConfig, PcTier},
    select::{self, AdapterDescription, Plan, RunsOn},
    tier::{
        FrameInput, FrameOutput, FrameTimings, Tier, TierChoice, TierError, TierKind, TierSettings,
    },
};

/// Which camera the frames look through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMode {
    /// The scene's default camera (moving with its node if the node is animated).
    Default,
    /// The scene's camera path (from its extras) at each frame's time.
    Path,
}

/// What one frame shows, as an engine asks for it each frame ([`Renderer::render`],
/// [`Renderer::submit`]): the scene's time and the camera. Left out, each comes from the
/// renderer: the time of its frame counter ([`Scene::frame_time`]) and the view of its
/// [`CameraMode`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameRequest {
    /// Scene time in seconds (animations are sampled at it).
    pub time_s: Option<f32>,
    /// The camera.
    pub camera: Option<CameraView>,
}

impl FrameRequest {
    /// The scene at `time_s`, through the renderer's camera.
    pub fn at(time_s: f32) -> Self {
        Self {
            time_s: Some(time_s),
            camera: None,
        }
    }

    /// This request through `camera`.
    pub fn with_camera(self, camera: CameraView) -> Self {
        Self {
            camera: Some(camera),
            ..self
        }
    }

    /// This request through the camera of an engine's view and projection matrices
    /// ([`CameraView::from_view_projection`]); an error when they make no perspective camera.
    pub fn with_view_projection(self, view: &Mat4, projection: &Mat4) -> Result<Self, TierError> {
        let camera = CameraView::from_view_projection(view, projection).ok_or_else(|| {
            TierError::InvalidRequest(
                "the view matrix is not invertible or the projection is not a perspective one"
                    .to_string(),
            )
        })?;
        Ok(self.with_camera(camera))
    }
}

/// Everything a [`Renderer`] is made from, set by name ([`Renderer::builder`]): the tier
/// choice, the frame settings, each tier's configuration, the camera mode and the device.
pub struct RendererBuilder {
    scene: Scene,
    choice: TierChoice,
    settings: TierSettings,
    camera: CameraMode,
    context: Option<GpuContext>,
    mobile: MobileConfig,
    pc: PcConfig,
}

impl RendererBuilder {
    /// The tier: `TierChoice::Auto` (the default), a budget (`TierChoice::AutoWithin`) or a
    /// [`TierKind`].
    pub fn tier(mut self, choice: impl Into<TierChoice>) -> Self {
        self.choice = choice.into();
        self
    }

    /// Image width and height in pixels (default 640 x 360).
    pub fn size(mut self, width: u32, height: u32) -> Self {
        self.settings.width = width;
        self.settings.height = height;
        self
    }

    /// Samples per pixel per frame (default 1): the accumulating tiers' samples per frame,
    /// the temporal tiers' cap on their direct light's accumulation.
    pub fn spp(mut self, spp: u32) -> Self {
        self.settings.spp = spp;
        self
    }

    /// The seed of every random number the tiers draw (default 1).
    pub fn seed(mut self, seed: u64) -> Self {
        self.settings.seed = seed;
        self
    }

    /// How textures are uploaded ([`TextureOptions::DEFAULT`] unless set).
    pub fn textures(mut self, textures: TextureOptions) -> Self {
        self.settings.textures = textures;
        self
    }

    /// All frame settings at once.
    pub fn settings(mut self, settings: TierSettings) -> Self {
        self.settings = settings;
        self
    }

    /// Which camera frames look through when a request names none (default
    /// [`CameraMode::Default`]).
    pub fn camera_mode(mut self, camera: CameraMode) -> Self {
        self.camera = camera;
        self
    }

    /// The mobile tier's configuration, used when the mobile tier is chosen.
    pub fn mobile_config(mut self, config: MobileConfig) -> Self {
        self.mobile = config;
        self
    }

    /// The PC tier's configuration, used when the PC tier is chosen.
    pub fn pc_config(mut self, config: PcConfig) -> Self {
        self.pc = config;
        self
    }

    /// Renders on the caller's device (an engine's, through [`GpuContext::from_device`]),
    /// whose textures then hold the output ([`Renderer::output_textures`]). Without it the
    /// GPU tiers open their own. `Auto` plans for this device's adapter.
    pub fn context(mut self, ctx: GpuContext) -> Self {
        self.context = Some(ctx);
        self
    }

    /// Creates the tier the choice resolves to. `Auto` and `AutoWithin` plan with
    /// [`select::plan`] and try the plan's candidates in order ([`Renderer::from_plan`]); a
    /// named tier is created or fails.
    pub fn build(self) -> Result<Renderer, TierError> {
        let configs = TierConfigs {
            mobile: self.mobile,
            pc: self.pc,
        };
        let settings = self.settings;
        if self.choice.is_auto() {
            let ctx = match self.context {
                Some(ctx) => Some(ctx),
                None => GpuContext::new()
                    .inspect_err(|e| tracing::info!("auto tier: no GPU context ({e})"))
                    .ok(),
            };
            let adapter = ctx.as_ref().map(AdapterDescription::from_context);
            let plan = select::plan(adapter.as_ref(), &settings, self.choice.budget());
            let adapter = adapter.map(|a| a.label());
            return Renderer::create_planned(
                self.scene,
                plan,
                settings,
                self.camera,
                Devices::new(ctx, adapter),
                &configs,
            );
        }
        let TierChoice::Tier(kind) = self.choice else {
            unreachable!("every other choice is auto");
        };
        let tier: Box<dyn Tier> = match (kind, self.context) {
            (TierKind::Reference, _) => Box::new(CpuTier::new(TierKind::Reference, settings)?),
            (TierKind::Direct, None) => match hardware_gpu() {
                Some(ctx) => create_gpu_tier(kind, settings, ctx, &configs)?,
                None => Box::new(CpuTier::new(TierKind::Direct, settings)?),
            },
            (_, Some(ctx)) => create_gpu_tier(kind, settings, ctx, &configs)?,
            (_, None) => {
                let ctx = GpuContext::new().map_err(|e| TierError::Unavailable {
                    tier: kind.name(),
                    reason: e.to_string(),
                })?;
                create_gpu_tier(kind, settings, ctx, &configs)?
            }
        };
        Ok(Renderer::with_tier(self.scene, tier, self.camera))
    }
}

/// The configurations of the configurable tiers.
struct TierConfigs {
    mobile: MobileConfig,
    pc: PcConfig,
}

/// The GPU contexts a plan's candidates are created on: the caller's device (each candidate
/// on a context of its own over it), or one the renderer opened for the first GPU candidate
/// and new ones for the next.
struct Devices {
    opened: Option<GpuContext>,
    adapter: Option<String>,
}

impl Devices {
    fn new(opened: Option<GpuContext>, adapter: Option<String>) -> Self {
        Self { opened, adapter }
    }

    fn next(&mut self) -> Result<GpuContext, gi_gpu::GpuError> {
        let ctx = match self.opened.take() {
            Some(ctx) => ctx,
            None => GpuContext::new()?,
        };
        self.adapter
            .get_or_insert_with(|| AdapterDescription::from_context(&ctx).label());
        Ok(ctx)
    }
}

/// What [`TierChoice::Auto`] or [`TierChoice::AutoWithin`] chose, and why
/// ([`Renderer::selection`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// The tier that renders.
    pub chosen: TierKind,
    /// Where it runs.
    pub runs_on: RunsOn,
    /// Why the policy proposed it ([`select::Candidate::reason`]).
    pub reason: String,
    /// The candidates tried before it, each with the error that stopped its creation.
    pub fallbacks: Vec<(TierKind, String)>,
    /// The adapter the plan was made for (`name (type)`); `None` without one.
    pub adapter: Option<String>,
    /// The whole plan: every candidate and the tiers it left out, with reasons.
    pub plan: Plan,
}

/// Renders the frames of one scene with one tier. Frame `i` shows the scene at time
/// `scene.frame_time(i)`.
pub struct Renderer {
    scene: Scene,
    tier: Box<dyn Tier>,
    camera: CameraMode,
    next_frame: u32,
    /// Still warm-up frames rendered so far ([`Renderer::warm_up`]); they show an existing
    /// frame again, so they do not advance `next_frame`.
    warm_up_frames: u32,
    selection: Option<Selection>,
    /// The last frame it evaluated. For a scene without animation, its triangles, lights and
    /// sky are the same at every time, so later frames take it with their own time and camera
    /// instead of transforming every triangle again (5 ms per frame for open-world's 43k on
    /// the development machine); for an animated one, later frames move it in place and
    /// evaluate only the animated nodes again. [`Renderer::scene_mut`] drops it.
    last_frame: Option<SceneFrame>,
    /// What each frame's evaluation leaves out: the normals and tangents of the meshes a GPU
    /// tier skins itself ([`Tier::skins_on_gpu`]). Fixed when the renderer is made, as the
    /// tier's upload of the scene fixes which meshes it skins; [`Renderer::scene_mut`] keeps
    /// it.
    evaluation: Evaluation,
    /// For a scene without a camera node, the view that frames it (its bounds at time 0,
    /// [`Scene::fallback_view`]: a pass over every vertex), computed once instead of every
    /// frame; `None` for a scene with a camera node. `framing_stale`: the scene was edited
    /// since ([`Renderer::scene_mut`]), so the next frame computes it again.
    framing: Option<CameraView>,
    framing_stale: bool,
    /// The caller changed a light since the last frame ([`Renderer::light_mut`]): the next
    /// frame evaluates the lights again though nothing else moved.
    lights_stale: bool,
    /// Edits of the materials so far ([`Renderer::set_material`]): every frame carries it as
    /// its [`SceneFrame::material_revision`].
    material_revision: u64,
    /// The textures of the last frame, made at the first [`Renderer::output_textures`].
    output: Option<OutputTextures>,
}

/// The view that frames `scene` when it has no camera node to look through, else `None`.
fn framing_of(scene: &Scene) -> Option<CameraView> {
    let camera = (scene.default_camera_node)
        .and_then(|node| scene.nodes.get(node))
        .and_then(|node| node.camera)
        .and_then(|camera| scene.cameras.get(camera));
    camera.is_none().then(|| scene.default_view(0.0))
}

/// The evaluation `tier` needs of `scene`'s frames.
fn evaluation_for(scene: &Scene, tier: &dyn Tier) -> Evaluation {
    if tier.skins_on_gpu() {
        Evaluation {
            positions_only: gi_gpu::gpu_skinned_nodes(scene),
        }
    } else {
        Evaluation::default()
    }
}

impl Renderer {
    /// A builder for a renderer of `scene`: `Auto` at 640 x 360, one sample per pixel, seed
    /// 1, default configurations, on a device of its own until told otherwise.
    pub fn builder(scene: Scene) -> RendererBuilder {
        RendererBuilder {
            scene,
            choice: TierChoice::Auto,
            settings: TierSettings {
                width: 640,
                height: 360,
                spp: 1,
                seed: 1,
                textures: TextureOptions::DEFAULT,
            },
            camera: CameraMode::Default,
            context: None,
            mobile: MobileConfig::default(),
            pc: PcConfig::default(),
        }
    }

    /// Creates the tier `choice` resolves to for `scene` with the default configurations:
    /// [`Renderer::builder`] with the choice, the settings and the camera mode.
    pub fn new(
        scene: Scene,
        choice: TierChoice,
        settings: TierSettings,
        camera: CameraMode,
    ) -> Result<Self, TierError> {
        Self::builder(scene)
            .tier(choice)
            .settings(settings)
            .camera_mode(camera)
            .build()
    }

    /// Creates the first candidate of `plan` that can be created, trying them in order: a
    /// candidate whose creation fails (no context, a limit, a pipeline that does not compile)
    /// is logged with `tracing::warn!`, recorded in [`Selection::fallbacks`], and the next is
    /// tried, each GPU candidate on a context of its own. For a plan [`select::plan`] made, or
    /// one the caller edited (e.g. without `pc`). Fails with the last candidate's error.
    pub fn from_plan(
        scene: Scene,
        plan: Plan,
        settings: TierSettings,
        camera: CameraMode,
    ) -> Result<Self, TierError> {
        let configs = TierConfigs {
            mobile: MobileConfig::default(),
            pc: PcConfig::default(),
        };
        Self::create_planned(
            scene,
            plan,
            settings,
            camera,
            Devices::new(None, None),
            &configs,
        )
    }

    /// [`Renderer::from_plan`] with a context already open for the first GPU candidate.
    fn create_planned(
        scene: Scene,
        plan: Plan,
        settings: TierSettings,
        camera: CameraMode,
        mut devices: Devices,
        configs: &TierConfigs,
    ) -> Result<Self, TierError> {
        let mut fallbacks = Vec::new();
        let mut last_error = None;
        for candidate in &plan.candidates {
            let kind = candidate.kind;
            let created = match candidate.runs_on {
                RunsOn::Cpu => CpuTier::new(kind, settings).map(|t| Box::new(t) as Box<dyn Tier>),
                RunsOn::Gpu => match devices.next() {
                    Ok(ctx) => create_gpu_tier(kind, settings, ctx, configs),
                    Err(e) => Err(TierError::Unavailable {
                        tier: kind.name(),
                        reason: e.to_string(),
                    }),
                },
            };
            match created {
                Ok(tier) => {
                    let mut renderer = Self::with_tier(scene, tier, camera);
                    renderer.selection = Some(Selection {
                        chosen: kind,
                        runs_on: candidate.runs_on,
                        reason: candidate.reason.clone(),
                        fallbacks,
                        adapter: devices.adapter,
                        plan,
                    });
                    return Ok(renderer);
                }
                Err(error) => {
                    tracing::warn!(
                        tier = kind.name(),
                        runs_on = ?candidate.runs_on,
                        "auto tier: {kind} could not be created, trying the next candidate: {error}"
                    );
                    fallbacks.push((kind, error.to_string()));
                    last_error = Some(error);
                }
            }
        }
        Err(last_error.unwrap_or(TierError::Unavailable {
            tier: "auto",
            reason: "the plan has no candidates".to_string(),
        }))
    }

    /// Renders `scene` with a tier the caller made, e.g. a [`MobileTier`] with another
    /// [`MobileConfig`] than the default `new` uses.
    pub fn with_tier(scene: Scene, tier: Box<dyn Tier>, camera: CameraMode) -> Self {
        Self {
            evaluation: evaluation_for(&scene, tier.as_ref()),
            framing: framing_of(&scene),
            framing_stale: false,
            scene,
            tier,
            camera,
            next_frame: 0,
            warm_up_frames: 0,
            selection: None,
            last_frame: None,
            lights_stale: false,
            material_revision: 0,
            output: None,
        }
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The scene, to change it between frames (e.g. turn a light to measure how fast a
    /// temporal tier settles). Every frame is evaluated from it afresh, but a tier may keep
    /// what it prepared from earlier frames ([`Tier::render`]): geometry always, and the CPU
    /// and path tiers their whole prepared scene until the camera or the animation time
    /// changes. So an edit reaches the image only through a tier that reads it per frame;
    /// meshes and the node count must not change (render another scene with a new
    /// `Renderer`), and materials change through [`Renderer::set_material`].
    pub fn scene_mut(&mut self) -> &mut Scene {
        self.last_frame = None;
        self.framing_stale = true;
        &mut self.scene
    }

    /// Moves node `node` for the next frames: its local translation, rotation and scale, as
    /// in glTF. Only the triangles under it are evaluated again; the rest of the frame is
    /// kept. The node must be [`gi_scene::Node::movable`] (set before the renderer was made, so
    /// every level treats it as moving); an animation that targets it overrides what is set
    /// here.
    pub fn set_node_transform(
        &mut self,
        node: usize,
        translation: Vec3,
        rotation: Quat,
        scale: Vec3,
    ) -> Result<(), TierError> {
        let count = self.scene.nodes.len();
        let target = self.scene.nodes.get_mut(node).ok_or_else(|| {
            TierError::InvalidRequest(format!("node {node} does not exist ({count} nodes)"))
        })?;
        if !target.movable {
            return Err(TierError::InvalidRequest(format!(
                "node {node} ('{}') is static: set its `movable` before making the renderer",
                target.name
            )));
        }
        let finite = translation.is_finite() && rotation.is_finite() && scale.is_finite();
        if !finite {
            return Err(TierError::InvalidRequest(format!(
                "node {node}: the transform is not finite"
            )));
        }
        target.translation = translation;
        target.rotation = rotation.normalize();
        target.scale = scale;
        Ok(())
    }

    /// Light `index` of the scene, to change its color, intensity, range or cone for the next
    /// frames (move it through its node). Only the lights are evaluated again.
    pub fn light_mut(&mut self, index: usize) -> Option<&mut Light> {
        self.lights_stale = true;
        self.scene.lights.get_mut(index)
    }

    /// Replaces material `index` for the next frames: its colors, emission, roughness,
    /// metallic, specular layer, cutoff and the like (a lamp switched off, a surface
    /// repainted). Its texture references and the kind of its alpha mode stay as loaded
    /// ([`gi_scene::Material::check_edit`]). Every tier takes the edit from the next frame:
    /// the GPU tiers upload the material and emitter tables again, and the brick cache
    /// voxelizes the bricks of the material's triangles again and follows the light it
    /// changed as it follows a light's change; the CPU and path tiers prepare the scene again.
    pub fn set_material(&mut self, index: usize, material: Material) -> Result<(), TierError> {
        let count = self.scene.materials.len();
        let current = self.scene.materials.get(index).ok_or_else(|| {
            TierError::InvalidRequest(format!(
                "material {index} does not exist ({count} materials)"
            ))
        })?;
        current.check_edit(&material).map_err(|reason| {
            TierError::InvalidRequest(format!(
                "material {index} ('{}') cannot be edited so: {reason}",
                current.name
            ))
        })?;
        if *current != material {
            self.scene.materials[index] = material;
            self.material_revision += 1;
        }
        Ok(())
    }

    pub fn tier(&self) -> TierKind {
        self.tier.kind()
    }

    /// What `Auto` chose and why; `None` when the tier was asked for by name or made by the
    /// caller.
    pub fn selection(&self) -> Option<&Selection> {
        self.selection.as_ref()
    }

    /// The tier as its concrete type, to reach what only that tier offers (the mobile tier's
    /// [`MobileTier::frame_data`] and [`MobileTier::memory`]); `None` if it is another type.
    pub fn tier_as<T: Tier>(&self) -> Option<&T> {
        let tier: &dyn Any = self.tier.as_ref();
        tier.downcast_ref()
    }

    /// Index of the frame the next call renders.
    pub fn next_frame(&self) -> u32 {
        self.next_frame
    }

    /// Scene time of frame `index`.
    pub fn frame_time(&self, index: u32) -> f32 {
        self.scene.frame_time(index)
    }

    /// The camera of frame `index`: the camera path's at its time ([`CameraMode::Path`] on a
    /// scene with one), else the default camera node's, else, for a scene without a camera
    /// node, the view that frames the scene's bounds at time 0 (also when an animation moves
    /// them later).
    pub fn view(&self, index: u32) -> CameraView {
        self.view_at_time(self.frame_time(index))
    }

    /// The camera at scene time `time` ([`Renderer::view`]).
    fn view_at_time(&self, time: f32) -> CameraView {
        let path = self
            .scene
            .camera_path
            .as_ref()
            .filter(|p| !p.keys.is_empty());
        match (self.camera, path, self.framing) {
            (CameraMode::Path, Some(_), _) => self.scene.path_view(time),
            (_, _, Some(framing)) if !self.framing_stale => framing,
            (_, _, _) => match framing_of(&self.scene) {
                Some(framing) => framing,
                None => self.scene.default_view(time),
            },
        }
    }

    /// Still warm-up frames rendered so far.
    pub fn warm_up_frames(&self) -> u32 {
        self.warm_up_frames
    }

    /// Renders the next frame.
    pub fn render_frame(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<FrameOutput, TierError> {
        let output = self.still(progress, |tier, input| tier.render(input))?;
        self.next_frame += 1;
        Ok(output)
    }

    /// Renders the frame `request` asks for and reads its image back (a GPU tier waits for
    /// the GPU): [`Renderer::submit`] is the engine's per-frame call, this one is for tools
    /// and tests. Advances the frame counter.
    pub fn render(&mut self, request: &FrameRequest) -> Result<FrameOutput, TierError> {
        let output = self.requested(request, None, |tier, input| tier.render(input))?;
        self.next_frame += 1;
        Ok(output)
    }

    /// Renders the frame `request` asks for without reading anything back or waiting for the
    /// GPU ([`Tier::submit`]), as an engine's frame loop runs; then
    /// [`Renderer::output_textures`] gives the frame as textures on the tier's device.
    /// Returns the passes of the frames the GPU has finished since the last call, oldest first.
    pub fn submit(&mut self, request: &FrameRequest) -> Result<Vec<FrameTimings>, TierError> {
        let reported = self.requested(request, None, |tier, input| tier.submit(input))?;
        self.next_frame += 1;
        Ok(reported)
    }

    /// The last frame as textures on the tier's device ([`OutputTextures`]: the composited
    /// image and the GI term, `rgba16float`), written now by one GPU pass that the queue
    /// orders after the frame. Made at the first call and again when the size changes.
    /// `None` for a tier that renders on the CPU and before the first frame.
    pub fn output_textures(&mut self) -> Result<Option<&OutputTextures>, TierError> {
        let Some(output) = self.tier.gpu_output() else {
            return Ok(None);
        };
        let fits = self
            .output
            .as_ref()
            .is_some_and(|textures| textures.size() == output.size);
        if !fits {
            if let Some(old) = self.output.take() {
                old.release(output.ctx);
            }
            let textures = OutputTextures::new(output.ctx, output.size).map_err(|e| {
                TierError::Unavailable {
                    tier: self.tier.kind().name(),
                    reason: e.to_string(),
                }
            })?;
            self.output = Some(textures);
        }
        let textures = self.output.as_ref().expect("made above");
        textures.write(&output);
        Ok(Some(textures))
    }

    /// The device the tier renders on; `None` for a CPU tier.
    pub fn context(&self) -> Option<&GpuContext> {
        self.tier.gpu_context()
    }

    /// Renders the next frame as [`Renderer::render_frame`] does but without its image
    /// ([`Tier::advance`]): for frames that are timed or only lead up to the one that is
    /// looked at. Returns the frame's passes.
    pub fn advance_frame(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<Vec<(String, f64)>, TierError> {
        let passes = self.still(progress, |tier, input| tier.advance(input))?;
        self.next_frame += 1;
        Ok(passes)
    }

    /// Renders the next frame as [`Renderer::advance_frame`] does without waiting for the
    /// GPU ([`Tier::submit`]), as an engine's frame loop runs: the CPU's work on the next
    /// frame overlaps the GPU's on this one. Returns the passes of the frames the GPU has
    /// finished since the last call, oldest first, each under its tier frame index (warm-up
    /// frames count, as in [`FrameInput::index`]); [`Renderer::flush_frames`] waits for the
    /// rest.
    pub fn submit_frame(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<Vec<FrameTimings>, TierError> {
        let reported = self.still(progress, |tier, input| tier.submit(input))?;
        self.next_frame += 1;
        Ok(reported)
    }

    /// Waits for every frame [`Renderer::submit_frame`] left in flight and returns their
    /// passes, oldest first.
    pub fn flush_frames(&mut self) -> Vec<FrameTimings> {
        self.tier.flush()
    }

    /// A still warm-up for temporal tiers: renders `frames` frames that all show the next
    /// frame (frame 0 on a new renderer: its time and camera) without advancing the frame
    /// counter, so history-based tiers converge on a still view before the frames that are
    /// measured. Tiers without history ([`Tier::is_temporal`] false) skip it. Each warm-up
    /// frame costs a full frame, though the frames do not wait for the GPU one by one
    /// ([`Tier::submit`]; the last is waited for); [`TierKind::default_warmup`] is how many a
    /// measurement of a tier wants. `progress` is called with the warm-up frames submitted so
    /// far.
    pub fn warm_up(
        &mut self,
        frames: u32,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<(), TierError> {
        if !self.tier.is_temporal() {
            return Ok(());
        }
        for done in 1..=frames {
            self.still(None, |tier, input| tier.submit(input))?;
            self.warm_up_frames += 1;
            if let Some(progress) = progress {
                progress(done);
            }
        }
        self.tier.flush();
        Ok(())
    }

    /// One still warm-up frame as [`Renderer::warm_up`] renders them, for any tier, returning
    /// its passes: for a caller that warms up until something it measures settles (a
    /// benchmark waiting for the GPU's clock to climb).
    pub fn warm_up_frame(&mut self) -> Result<Vec<(String, f64)>, TierError> {
        let passes = self.still(None, |tier, input| tier.advance(input))?;
        self.warm_up_frames += 1;
        Ok(passes)
    }

    /// Renders the next frame through `render` (the tier's `render` or `advance`) without
    /// advancing the frame counter. The tier's frame index counts every frame it rendered,
    /// warm-up included.
    fn still<T>(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
        render: impl FnOnce(&mut dyn Tier, &FrameInput) -> Result<T, TierError>,
    ) -> Result<T, TierError> {
        self.requested(&FrameRequest::default(), progress, render)
    }

    /// [`Renderer::still`] for the frame `request` asks for.
    fn requested<T>(
        &mut self,
        request: &FrameRequest,
        progress: Option<&(dyn Fn(u32) + Sync)>,
        render: impl FnOnce(&mut dyn Tier, &FrameInput) -> Result<T, TierError>,
    ) -> Result<T, TierError> {
        let frame = self.frame(self.next_frame, request);
        let result = render(
            self.tier.as_mut(),
            &FrameInput {
                scene: &self.scene,
                frame: &frame,
                index: self.next_frame + self.warm_up_frames,
                progress,
            },
        );
        self.last_frame = Some(frame);
        result
    }

    /// The scene at frame `index`: for a scene without animation the last evaluation with
    /// this frame's time and camera; for an animated one the last evaluation moved to this
    /// frame ([`Scene::evaluate_into`]: only the animated nodes' triangles are evaluated
    /// again); else a fresh evaluation.
    fn frame(&mut self, index: u32, request: &FrameRequest) -> SceneFrame {
        if self.framing_stale {
            self.framing = framing_of(&self.scene);
            self.framing_stale = false;
        }
        let time_s = request.time_s.unwrap_or_else(|| self.frame_time(index));
        let view_at = |renderer: &Self| match request.camera {
            Some(camera) => camera,
            None => renderer.view_at_time(time_s),
        };
        let mut frame = match self.last_frame.take() {
            Some(mut frame) if !self.scene.is_animated() => {
                frame.time_s = time_s;
                // Without animation only a camera path or the request moves the camera: the
                // default view (a camera node, or a framing of the scene's bounds, which is a
                // pass over every vertex) is the same at every time.
                let path = self.scene.camera_path.as_ref();
                let on_path =
                    self.camera == CameraMode::Path && path.is_some_and(|p| !p.keys.is_empty());
                if on_path || request.camera.is_some() {
                    frame.camera = view_at(self);
                }
                frame
            }
            Some(mut frame) => {
                let camera = Some(view_at(self));
                let scene = &self.scene;
                scene.evaluate_into(&mut frame, time_s, camera, &self.evaluation);
                frame
            }
            None => {
                let camera = Some(view_at(self));
                (self.scene).evaluate_with(time_s, camera, &self.evaluation)
            }
        };
        if self.lights_stale {
            frame.lights = self.scene.world_lights(&frame.world_from_node);
            self.lights_stale = false;
        }
        frame.material_revision = self.material_revision;
        frame
    }

    /// Advances `count` frames (at least one) and returns the last: warm-up frames, then the
    /// measured one. Tiers without history skip straight to the last frame.
    pub fn render_frames(
        &mut self,
        count: u32,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<FrameOutput, TierError> {
        let count = count.max(1);
        if !self.tier.is_temporal() {
            self.next_frame += count - 1;
        } else {
            for _ in 1..count {
                self.submit_frame(None)?;
            }
            self.flush_frames();
        }
        self.render_frame(progress)
    }

    /// Bytes the tier owns now.
    pub fn memory_bytes(&self) -> u64 {
        self.tier.memory_bytes()
    }
}

/// A context on a hardware GPU, or `None` when there is no adapter or only a software one
/// (which runs the GPU tiers slower than the CPU runs the reference).
fn hardware_gpu() -> Option<GpuContext> {
    GpuContext::new()
        .ok()
        .filter(|ctx| ctx.adapter_info.device_type != wgpu::DeviceType::Cpu)
}

/// The GPU version of `kind` on `ctx`, with the configuration `configs` holds for it.
fn create_gpu_tier(
    kind: TierKind,
    settings: TierSettings,
    ctx: GpuContext,
    configs: &TierConfigs,
) -> Result<Box<dyn Tier>, TierError> {
    Ok(match kind {
        TierKind::Mobile => Box::new(MobileTier::new(settings, configs.mobile.clone(), ctx)?),
        TierKind::Pc => Box::new(PcTier::new(settings, configs.pc.clone(), ctx)?),
        // `reference` has no GPU version: GpuPathTier says so.
        TierKind::Direct | TierKind::Path | TierKind::Reference => {
            Box::new(GpuPathTier::new(kind, settings, ctx)?)
        }
    })
}
