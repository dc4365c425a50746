//! The [`Renderer`] facade: a scene, a tier and a frame counter, and the creation of the tier
//! a [`TierChoice`] asks for, trying the candidates of a [`Plan`] in order for `Auto`.

use std::any::Any;

use gi_scene::{CameraView, Evaluation, Scene, SceneFrame};

use gi_gpu::{GpuContext, wgpu};

use crate::{
    cpu::CpuTier,
    mobile::{MobileConfig, MobileTier},
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
    /// Creates the tier `choice` resolves to for `scene`. `Auto` and `AutoWithin` open the
    /// GPU context once, plan with [`select::plan`] and try the plan's candidates in order
    /// ([`Renderer::from_plan`]); the other choices create their tier or fail.
    pub fn new(
        scene: Scene,
        choice: TierChoice,
        settings: TierSettings,
        camera: CameraMode,
    ) -> Result<Self, TierError> {
        let tier: Box<dyn Tier> = match choice {
            TierChoice::Auto | TierChoice::AutoWithin(_) => {
                let ctx = GpuContext::new()
                    .inspect_err(|e| tracing::info!("auto tier: no GPU context ({e})"))
                    .ok();
                let adapter = ctx.as_ref().map(AdapterDescription::from_context);
                let plan = select::plan(adapter.as_ref(), &settings, choice.budget());
                let adapter = adapter.map(|a| a.label());
                return Self::create_planned(scene, plan, settings, camera, ctx, adapter);
            }
            TierChoice::Tier(TierKind::Mobile) => {
                Box::new(MobileTier::open(settings, MobileConfig::default())?)
            }
            TierChoice::Tier(TierKind::Pc) => {
                Box::new(PcTier::open(settings, PcConfig::default())?)
            }
            TierChoice::Tier(TierKind::Path) => {
                Box::new(GpuPathTier::open(TierKind::Path, settings)?)
            }
            TierChoice::Tier(TierKind::Direct) => match hardware_gpu() {
                Some(ctx) => Box::new(GpuPathTier::new(TierKind::Direct, settings, ctx)?),
                None => Box::new(CpuTier::new(TierKind::Direct, settings)?),
            },
            TierChoice::Tier(TierKind::Reference) => {
                Box::new(CpuTier::new(TierKind::Reference, settings)?)
            }
        };
        Ok(Self::with_tier(scene, tier, camera))
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
        Self::create_planned(scene, plan, settings, camera, None, None)
    }

    /// [`Renderer::from_plan`] with a context already open for the first GPU candidate.
    fn create_planned(
        scene: Scene,
        plan: Plan,
        settings: TierSettings,
        camera: CameraMode,
        mut ctx: Option<GpuContext>,
        mut adapter: Option<String>,
    ) -> Result<Self, TierError> {
        let mut fallbacks = Vec::new();
        let mut last_error = None;
        for candidate in &plan.candidates {
            let kind = candidate.kind;
            let created = match candidate.runs_on {
                RunsOn::Cpu => CpuTier::new(kind, settings).map(|t| Box::new(t) as Box<dyn Tier>),
                RunsOn::Gpu => match ctx.take().map_or_else(GpuContext::new, Ok) {
                    Ok(ctx) => {
                        adapter
                            .get_or_insert_with(|| AdapterDescription::from_context(&ctx).label());
                        create_gpu_tier(kind, settings, ctx)
                    }
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
                        adapter,
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
    /// meshes, materials and the node count must not change (render another scene with a new
    /// `Renderer`).
    pub fn scene_mut(&mut self) -> &mut Scene {
        self.last_frame = None;
        self.framing_stale = true;
        &mut self.scene
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
        let time = self.frame_time(index);
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
        let frame = self.frame(self.next_frame);
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
    fn frame(&mut self, index: u32) -> SceneFrame {
        if self.framing_stale {
            self.framing = framing_of(&self.scene);
            self.framing_stale = false;
        }
        let time_s = self.frame_time(index);
        match self.last_frame.take() {
            Some(mut frame) if !self.scene.is_animated() => {
                frame.time_s = time_s;
                // Without animation only a camera path moves the camera: the default view
                // (a camera node, or a framing of the scene's bounds, which is a pass over
                // every vertex) is the same at every time.
                let path = self.scene.camera_path.as_ref();
                if self.camera == CameraMode::Path && path.is_some_and(|p| !p.keys.is_empty()) {
                    frame.camera = self.view(index);
                }
                frame
            }
            Some(mut frame) => {
                let camera = Some(self.view(index));
                let scene = &self.scene;
                scene.evaluate_into(&mut frame, time_s, camera, &self.evaluation);
                frame
            }
            None => {
                let camera = Some(self.view(index));
                (self.scene).evaluate_with(time_s, camera, &self.evaluation)
            }
        }
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

/// The GPU version of `kind` on `ctx`, with its default configuration.
fn create_gpu_tier(
    kind: TierKind,
    settings: TierSettings,
    ctx: GpuContext,
) -> Result<Box<dyn Tier>, TierError> {
    Ok(match kind {
        TierKind::Mobile => Box::new(MobileTier::new(settings, MobileConfig::default(), ctx)?),
        TierKind::Pc => Box::new(PcTier::new(settings, PcConfig::default(), ctx)?),
        // `reference` has no GPU version: GpuPathTier says so.
        TierKind::Direct | TierKind::Path | TierKind::Reference => {
            Box::new(GpuPathTier::new(kind, settings, ctx)?)
        }
    })
}
