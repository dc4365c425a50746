//! The CPU tiers: the reference path tracer and the direct-only baseline, both on
//! gi-reference.

use std::time::Instant;

use gi_reference::{Mode, Reference, RenderSettings, Strategy};
use gi_scene::{CameraView, SceneFrame};

use crate::tier::{FrameInput, FrameOutput, Tier, TierError, TierKind, TierSettings};

/// A CPU tier. It keeps the prepared scene (BVH and emitter table) between frames while the
/// scene and camera stay the same, and rebuilds it when either moves.
pub struct CpuTier {
    kind: TierKind,
    settings: TierSettings,
    prepared: Option<Prepared>,
}

struct Prepared {
    /// The frame it was made for, without its geometry.
    previous: SceneFrame,
    camera: CameraView,
    reference: Reference,
}

impl CpuTier {
    /// A CPU tier of `kind` (`Reference` or `Direct`).
    pub fn new(kind: TierKind, settings: TierSettings) -> Result<Self, TierError> {
        if matches!(kind, TierKind::Path | TierKind::Mobile | TierKind::Pc) {
            return Err(TierError::Unavailable {
                tier: kind.name(),
                reason: format!("the {kind} tier runs on the GPU only"),
            });
        }
        render_settings(kind, &settings).validate()?;
        Ok(Self {
            kind,
            settings,
            prepared: None,
        })
    }
}

/// The reference's settings for a CPU render of `kind`'s transport (`Direct`: Mode::Direct,
/// anything else: full transport).
pub(crate) fn render_settings(kind: TierKind, settings: &TierSettings) -> RenderSettings {
    RenderSettings {
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        seed: settings.seed,
        mode: match kind {
            TierKind::Direct => Mode::Direct,
            TierKind::Reference | TierKind::Path | TierKind::Mobile | TierKind::Pc => Mode::Full,
        },
        strategy: Strategy::Mis,
        ..RenderSettings::default()
    }
}

impl Tier for CpuTier {
    fn kind(&self) -> TierKind {
        self.kind
    }

    fn is_temporal(&self) -> bool {
        false
    }

    fn render(&mut self, input: &FrameInput) -> Result<FrameOutput, TierError> {
        let mut passes = Vec::new();
        let frame = input.frame;
        let reusable = self.prepared.as_ref().is_some_and(|p| {
            p.camera == frame.camera
                && !frame.content_changed_from(&p.previous)
                && (p.previous.time_s == frame.time_s || !input.scene.is_animated())
        });
        if !reusable {
            let started = Instant::now();
            self.prepared = Some(Prepared {
                previous: frame.without_geometry(),
                camera: frame.camera,
                reference: Reference::new(input.scene, frame.clone()),
            });
            passes.push((
                "scene/prepare".to_string(),
                started.elapsed().as_secs_f64() * 1e3,
            ));
        }
        let reference = &self.prepared.as_ref().expect("prepared above").reference;
        let settings = render_settings(self.kind, &self.settings);
        let output = reference.render(&settings, input.progress.unwrap_or(&|_| {}))?;
        passes.push((
            format!("{}/trace", self.kind.name()),
            output.stats.seconds * 1e3,
        ));
        Ok(FrameOutput {
            image: output.image,
            passes,
            stats: Some(output.stats),
        })
    }

    fn memory_bytes(&self) -> u64 {
        let accumulation = u64::from(self.settings.width) * u64::from(self.settings.height) * 12;
        self.prepared
            .as_ref()
            .map_or(0, |p| p.reference.memory_bytes())
            + accumulation
    }
}
