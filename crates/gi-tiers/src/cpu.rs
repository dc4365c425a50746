//! The CPU tiers: the reference path tracer and the direct-only baseline, both on
//! gi-reference.

use std::{sync::Arc, time::Instant};

use gi_reference::{Mode, Reference, RenderSettings, Strategy};
use gi_scene::{CameraView, SceneFrame};

use crate::tier::{FrameInput, FrameOutput, Tier, TierError, TierKind, TierSettings};

/// A CPU tier. It keeps the prepared scene (BVH and emitter table) between frames while the
/// scene and camera stay the same, and rebuilds it when either moves.
pub struct CpuTier {
    kind: TierKind,
    settings: TierSettings,
    prepared: Option<Prepared>,
    cancelled: Option<CancelCheck>,
}

/// What a long CPU frame asks between its passes: stop now?
pub type CancelCheck = Arc<dyn Fn() -> bool + Send + Sync>;

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
            cancelled: None,
        })
    }

    /// The tier, stopping a frame between its passes (about 65k paths each) once `cancelled`
    /// answers true: the frame then fails with [`TierError::Cancelled`]. For a service whose
    /// jobs can be cancelled or timed out while one long frame renders.
    pub fn with_cancel(mut self, cancelled: CancelCheck) -> Self {
        self.cancelled = Some(cancelled);
        self
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
        let progress = input.progress.unwrap_or(&|_| {});
        let output = match &self.cancelled {
            Some(cancelled) => reference
                .render_until(&settings, progress, cancelled.as_ref())?
                .ok_or(TierError::Cancelled)?,
            None => reference.render(&settings, progress)?,
        };
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

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicU32, Ordering};

    use super::*;
    use crate::{CameraMode, Renderer, TextureOptions};

    /// A frame whose cancel check answers true after `passes` passes stops there, with
    /// [`TierError::Cancelled`]; one never cancelled renders every sample.
    #[test]
    fn a_cancelled_frame_stops_between_its_passes() {
        let settings = TierSettings {
            width: 256,
            height: 256,
            // 65,536 paths a pass at 256 x 256: one sample per pixel each.
            spp: 64,
            seed: 1,
            textures: TextureOptions::DEFAULT,
        };
        let checks = Arc::new(AtomicU32::new(0));
        let counted = checks.clone();
        let tier = CpuTier::new(TierKind::Direct, settings)
            .unwrap()
            .with_cancel(Arc::new(move || {
                counted.fetch_add(1, Ordering::SeqCst) >= 3
            }));
        let scene = gi_scene::load("cornell-box").unwrap();
        let mut renderer = Renderer::with_tier(scene.clone(), Box::new(tier), CameraMode::Default);
        let done = std::sync::Mutex::new(0);
        let progress = |spp: u32| *done.lock().unwrap() = spp;
        assert!(matches!(
            renderer.render_frame(Some(&progress)),
            Err(TierError::Cancelled)
        ));
        assert_eq!(checks.load(Ordering::SeqCst), 4);
        assert_eq!(*done.lock().unwrap(), 3, "three passes of one sample each");

        let tier = CpuTier::new(TierKind::Direct, settings)
            .unwrap()
            .with_cancel(Arc::new(|| false));
        let mut renderer = Renderer::with_tier(scene, Box::new(tier), CameraMode::Default);
        let frame = renderer.render_frame(None).unwrap();
        assert_eq!(frame.stats.unwrap().samples, 64 * 256 * 256);
    }
}
