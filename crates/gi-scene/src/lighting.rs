//! Lighting files: sun, sky, exposure and camera for scenes that bring none of their own.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use crate::generate::{SUN_COLOR, SUN_IRRADIANCE};
use crate::{Light, LightKind, Node, Scene, SceneError, Sky};

/// Name of the node and light [`Lighting::apply`] adds for the sun.
pub const LIGHTING_SUN_NAME: &str = "lighting-file sun";

/// A lighting file: the sun, sky, exposure and default camera of a scene that has none.
///
/// Many third-party glTF scenes carry no lights (their renderers add sun and sky from their own
/// settings), so they render black. A lighting file is a small JSON document that supplies them;
/// every field is optional:
///
/// ```json
/// {
///   "sun": { "azimuth_deg": 30, "elevation_deg": 60, "color": [1.0, 0.95, 0.87], "irradiance": 8 },
///   "sky": { "preset": "day" },
///   "exposure": 0.6,
///   "camera": "Camera_1"
/// }
/// ```
///
/// - `sun`: a directional light. Its direction is either `direction`, the vector the light
///   travels along (world space, +Y up; `[0, -1, 0]` shines straight down), or `azimuth_deg` and
///   `elevation_deg`, the direction *towards* the sun: elevation in degrees above the horizon,
///   azimuth in degrees from +X towards +Z. `color` is linear RGB (default `[1.0, 0.95, 0.87]`),
///   `irradiance` the W/m^2 on a surface facing the sun (default 8, the bundled outdoor
///   scenes' sun; directional lights use lux-like units).
/// - `sky`: radiance of the directions that escape the scene, one of `{"constant": [r, g, b]}`,
///   `{"gradient": {"zenith": [..], "horizon": [..], "ground": [..]}}` (linear RGB in
///   W/(sr m^2), see [`Sky::Gradient`]) or `{"preset": NAME}` with NAME `day` (the bundled
///   outdoor scenes' clear sky, balanced against the default sun), `overcast` (a bright even
///   grey) or `night` (a faint blue).
/// - `exposure`: the scene's [`Scene::exposure`], positive.
/// - `camera`: the default view: the name of a node with a camera (or of the camera itself),
///   or the index of a camera node in the scene's node order (0 is the first camera node).
///
/// [`load_with_lighting`](crate::load_with_lighting) picks up `<stem>.lighting.json` beside
/// `<stem>.gltf` or `<stem>.glb` when no file is given explicitly.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lighting {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun: Option<Sun>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky: Option<SkySetting>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraChoice>,
}

/// A directional light: `direction`, or `azimuth_deg` with `elevation_deg`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sun {
    /// The vector the light travels along (need not be unit length).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f32; 3]>,
    /// Direction towards the sun in the horizontal plane: degrees from +X towards +Z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub azimuth_deg: Option<f32>,
    /// Degrees of the sun above the horizon.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elevation_deg: Option<f32>,
    /// Linear RGB.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<[f32; 3]>,
    /// W/m^2 on a surface facing the sun.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiance: Option<f32>,
}

/// The sky of a lighting file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum SkySetting {
    /// The same radiance from every direction.
    Constant([f32; 3]),
    /// [`Sky::Gradient`].
    Gradient {
        zenith: [f32; 3],
        horizon: [f32; 3],
        ground: [f32; 3],
    },
    /// A named sky.
    Preset(SkyPreset),
}

/// The named skies of lighting files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SkyPreset {
    /// The bundled outdoor scenes' clear sky, balanced against the default sun.
    Day,
    /// A bright, even grey sky, for scenes lit without a sun.
    Overcast,
    /// A faint blue sky.
    Night,
}

impl SkyPreset {
    /// The preset's sky.
    pub fn sky(self) -> Sky {
        match self {
            SkyPreset::Day => crate::generate::daylight_sky(),
            SkyPreset::Overcast => Sky::Gradient {
                zenith: Vec3::new(0.60, 0.62, 0.66),
                horizon: Vec3::new(0.48, 0.49, 0.51),
                ground: Vec3::new(0.12, 0.12, 0.11),
            },
            SkyPreset::Night => Sky::Gradient {
                zenith: Vec3::new(0.002, 0.003, 0.008),
                horizon: Vec3::new(0.004, 0.005, 0.010),
                ground: Vec3::new(0.001, 0.001, 0.001),
            },
        }
    }
}

/// Which camera a lighting file makes the default view.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum CameraChoice {
    /// The n-th node with a camera, in the scene's node order.
    Index(usize),
    /// The name of a node with a camera, or of its camera.
    Name(String),
}

impl Lighting {
    /// Reads and validates a lighting file.
    pub fn from_path(path: &Path) -> Result<Lighting, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Lighting::from_json(&text, &path.display().to_string())
    }

    /// Parses and validates lighting JSON; `origin` names it in errors.
    pub fn from_json(text: &str, origin: &str) -> Result<Lighting, SceneError> {
        let lighting: Lighting = serde_json::from_str(text).map_err(|e| SceneError::Lighting {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        lighting
            .validate()
            .map_err(|message| SceneError::Lighting {
                origin: origin.to_string(),
                message,
            })?;
        Ok(lighting)
    }

    /// Checks every value: finite numbers, non-negative colors and irradiance, a positive
    /// exposure, one way of giving the sun's direction and a direction that is not zero.
    pub fn validate(&self) -> Result<(), String> {
        let color = |what: &str, c: [f32; 3]| {
            if c.iter().all(|v| v.is_finite() && *v >= 0.0) {
                Ok(())
            } else {
                Err(format!("{what} must be three finite non-negative numbers"))
            }
        };
        if let Some(sun) = &self.sun {
            sun.direction()?;
            if let Some(c) = sun.color {
                color("sun.color", c)?;
            }
            if let Some(e) = sun.irradiance
                && !(e.is_finite() && e >= 0.0)
            {
                return Err(format!(
                    "sun.irradiance must be finite and non-negative, not {e}"
                ));
            }
        }
        match &self.sky {
            Some(SkySetting::Constant(c)) => color("sky.constant", *c)?,
            Some(SkySetting::Gradient {
                zenith,
                horizon,
                ground,
            }) => {
                color("sky.gradient.zenith", *zenith)?;
                color("sky.gradient.horizon", *horizon)?;
                color("sky.gradient.ground", *ground)?;
            }
            Some(SkySetting::Preset(_)) | None => {}
        }
        if let Some(e) = self.exposure
            && !(e.is_finite() && e > 0.0)
        {
            return Err(format!("exposure must be positive and finite, not {e}"));
        }
        Ok(())
    }

    /// Applies the lighting to `scene`: adds the sun as a directional light on a new root node,
    /// and replaces the sky, the exposure and the default camera where the file gives them.
    /// Fails, leaving `scene` unchanged, when the values are invalid or the camera is not in
    /// the scene (the error lists the cameras there are).
    pub fn apply(&self, scene: &mut Scene) -> Result<(), SceneError> {
        let invalid = |message: String| SceneError::Lighting {
            origin: format!("lighting for scene '{}'", scene.name),
            message,
        };
        self.validate().map_err(invalid)?;
        let camera_node = match &self.camera {
            Some(choice) => Some(camera_node(scene, choice).map_err(invalid)?),
            None => None,
        };

        if let Some(sun) = &self.sun {
            let direction = sun.direction().map_err(invalid)?;
            scene.lights.push(Light {
                name: LIGHTING_SUN_NAME.to_string(),
                kind: LightKind::Directional,
                color: sun.color.map_or(SUN_COLOR, Vec3::from),
                intensity: sun.irradiance.unwrap_or(SUN_IRRADIANCE),
                range: None,
            });
            // KHR_lights_punctual: the light shines down its node's -Z.
            scene.nodes.push(Node {
                name: LIGHTING_SUN_NAME.to_string(),
                rotation: Quat::from_rotation_arc(Vec3::NEG_Z, direction),
                light: Some(scene.lights.len() - 1),
                ..Node::default()
            });
        }
        if let Some(sky) = &self.sky {
            scene.sky = match *sky {
                SkySetting::Constant(c) => Sky::Constant {
                    radiance: Vec3::from(c),
                },
                SkySetting::Gradient {
                    zenith,
                    horizon,
                    ground,
                } => Sky::Gradient {
                    zenith: Vec3::from(zenith),
                    horizon: Vec3::from(horizon),
                    ground: Vec3::from(ground),
                },
                SkySetting::Preset(preset) => preset.sky(),
            };
        }
        if let Some(exposure) = self.exposure {
            scene.exposure = exposure;
        }
        if camera_node.is_some() {
            scene.default_camera_node = camera_node;
        }
        Ok(())
    }
}

impl Sun {
    /// The unit vector the light travels along.
    pub fn direction(&self) -> Result<Vec3, String> {
        let direction = match (self.direction, self.azimuth_deg, self.elevation_deg) {
            (Some(d), None, None) => Vec3::from(d),
            (None, Some(azimuth), Some(elevation)) => {
                -crate::generate::sun_direction(azimuth, elevation)
            }
            (None, None, None) => {
                return Err(
                    "sun needs a direction: \"direction\", or \"azimuth_deg\" and \"elevation_deg\""
                        .into(),
                );
            }
            (Some(_), _, _) => {
                return Err(
                    "sun gives both \"direction\" and azimuth/elevation; give one of them".into(),
                );
            }
            (None, _, _) => {
                return Err(
                    "sun needs both \"azimuth_deg\" and \"elevation_deg\" when it gives one".into(),
                );
            }
        };
        direction
            .try_normalize()
            .ok_or_else(|| "sun direction must be finite and not zero".to_string())
    }
}

/// The model index of the camera node `choice` names.
fn camera_node(scene: &Scene, choice: &CameraChoice) -> Result<usize, String> {
    let cameras: Vec<usize> = scene
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.camera.is_some())
        .map(|(i, _)| i)
        .collect();
    let found = match choice {
        CameraChoice::Index(i) => cameras.get(*i).copied(),
        CameraChoice::Name(name) => cameras
            .iter()
            .copied()
            .find(|&i| scene.nodes[i].name == *name)
            .or_else(|| {
                cameras.iter().copied().find(|&i| {
                    scene.nodes[i]
                        .camera
                        .and_then(|c| scene.cameras.get(c))
                        .is_some_and(|c| c.name == *name)
                })
            }),
    };
    found.ok_or_else(|| {
        let wanted = match choice {
            CameraChoice::Index(i) => format!("camera {i}"),
            CameraChoice::Name(name) => format!("camera \"{name}\""),
        };
        if cameras.is_empty() {
            format!("{wanted} does not exist: the scene has no camera")
        } else {
            let available: Vec<String> = cameras
                .iter()
                .enumerate()
                .map(|(k, &i)| format!("{k} \"{}\"", scene.nodes[i].name))
                .collect();
            format!(
                "{wanted} does not exist; the scene's cameras are {}",
                available.join(", ")
            )
        }
    })
}

/// Where the lighting file of scene file `scene_path` would be: `<stem>.lighting.json` in the
/// same folder.
pub fn lighting_path_for(scene_path: &Path) -> PathBuf {
    let stem = scene_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    scene_path.with_file_name(format!("{stem}.lighting.json"))
}

/// The warning for a scene that nothing lights: no punctual light, no emissive material and a
/// black sky. `None` when something emits.
pub fn no_emitter_warning(scene: &Scene) -> Option<String> {
    let lit_nodes = scene
        .nodes
        .iter()
        .filter_map(|n| n.light)
        .filter_map(|l| scene.lights.get(l))
        .any(|l| l.intensity > 0.0 && l.color.max_element() > 0.0);
    let emissive = scene
        .materials
        .iter()
        .any(|m| m.emissive.max_element() > 0.0);
    if lit_nodes || emissive || !scene.sky.is_black() {
        None
    } else {
        Some(format!(
            "scene '{}' has no light, no emissive material and a black sky: it renders black; add a lighting file (see `gi_scene::Lighting`)",
            scene.name
        ))
    }
}
