//! The product's own settings, stored under `"gi"` in glTF `extras` (documented in
//! `scenes/README.md`; the exporter writes the same format).
//!
//! Scene extras carry the sky, exposure, frame time, default camera and camera path; node extras
//! carry a simple translation path, so any glTF tool can author motion with custom properties.
//! Every field is optional. A present but malformed field is an error naming it; an unknown key
//! is a warning, so newer files still load.

use glam::Vec3;
use gltf::json;
use serde_json::{Map, Value};

use super::{Failure, Result, Warnings, unusable};
use crate::{CameraKey, CameraPath, Channel, ChannelValues, Interpolation, Sky};

/// Vertical field of view of a camera path that does not give one (the fallback view's).
const DEFAULT_PATH_YFOV: f32 = 0.8;

/// Render settings from the scene's extras, with the defaults for what is absent.
pub(super) struct SceneSettings {
    pub sky: Sky,
    pub exposure: f32,
    pub frame_time_s: f32,
    /// Name of the node whose camera is the default view.
    pub camera: Option<String>,
    pub camera_path: Option<CameraPath>,
}

impl Default for SceneSettings {
    fn default() -> Self {
        Self {
            sky: Sky::default(),
            exposure: 1.0,
            frame_time_s: 1.0 / 30.0,
            camera: None,
            camera_path: None,
        }
    }
}

/// Reads the settings from a scene's extras (`None`: the file has no scene).
pub(super) fn scene_settings(
    extras: Option<&json::Extras>,
    warnings: &mut Warnings,
) -> Result<SceneSettings> {
    let mut settings = SceneSettings::default();
    let owner = "scene extras";
    let Some(gi) = gi_object(extras, owner)? else {
        return Ok(settings);
    };
    let at = |key: &str| format!("{owner}: gi.{key}");
    warn_unknown(
        &gi,
        &["sky", "exposure", "frame_time_s", "camera", "camera_path"],
        &format!("{owner}: gi"),
        warnings,
    );
    if let Some(v) = gi.get("sky") {
        settings.sky = sky(v, &at("sky"), warnings)?;
    }
    if let Some(v) = gi.get("exposure") {
        settings.exposure = positive(v, &at("exposure"))?;
    }
    if let Some(v) = gi.get("frame_time_s") {
        settings.frame_time_s = positive(v, &at("frame_time_s"))?;
    }
    if let Some(v) = gi.get("camera") {
        let name = v
            .as_str()
            .ok_or_else(|| error(&at("camera"), "expected a node name"))?;
        settings.camera = Some(name.to_string());
    }
    if let Some(v) = gi.get("camera_path") {
        settings.camera_path = Some(camera_path(v, &at("camera_path"), warnings)?);
    }
    Ok(settings)
}

/// The translation path in a node's extras as a linear channel of model node `node`
/// (`name` identifies the node in messages).
pub(super) fn node_path(
    extras: &json::Extras,
    name: &str,
    node: usize,
    warnings: &mut Warnings,
) -> Result<Option<Channel>> {
    let owner = format!("node \"{name}\" extras");
    let Some(gi) = gi_object(Some(extras), &owner)? else {
        return Ok(None);
    };
    warn_unknown(&gi, &["path"], &format!("{owner}: gi"), warnings);
    let Some(path) = gi.get("path") else {
        return Ok(None);
    };
    let at = format!("{owner}: gi.path");
    let map = object(path, &at)?;
    warn_unknown(map, &["times", "translations"], &at, warnings);
    let times_at = format!("{at}.times");
    let times = required_array(map, "times", &at)?
        .iter()
        .enumerate()
        .map(|(i, v)| number(v, &format!("{times_at}[{i}]")))
        .collect::<Result<Vec<f32>>>()?;
    let translations = required_array(map, "translations", &at)?
        .iter()
        .enumerate()
        .map(|(i, v)| vec3(v, &format!("{at}.translations[{i}]")))
        .collect::<Result<Vec<Vec3>>>()?;
    if times.is_empty() {
        return Err(error(&times_at, "expected at least one key"));
    }
    if times.len() != translations.len() {
        return Err(error(
            &at,
            &format!(
                "{} times but {} translations",
                times.len(),
                translations.len()
            ),
        ));
    }
    strictly_increasing(&times, &times_at)?;
    Ok(Some(Channel {
        node,
        times,
        values: ChannelValues::Translation(translations),
        interpolation: Interpolation::Linear,
    }))
}

/// The `"gi"` object of some extras; `None` when the extras are absent, not an object, or
/// have no `"gi"` key (they belong to other tools then).
fn gi_object(extras: Option<&json::Extras>, owner: &str) -> Result<Option<Map<String, Value>>> {
    let Some(raw) = extras.and_then(|e| e.as_ref()) else {
        return Ok(None);
    };
    let value: Value =
        serde_json::from_str(raw.get()).map_err(|e| unusable(format!("{owner}: {e}")))?;
    match value.get("gi") {
        None => Ok(None),
        Some(Value::Object(map)) => Ok(Some(map.clone())),
        Some(_) => Err(error(&format!("{owner}: gi"), "expected an object")),
    }
}

fn sky(value: &Value, at: &str, warnings: &mut Warnings) -> Result<Sky> {
    let map = object(value, at)?;
    warn_unknown(map, &["constant", "gradient"], at, warnings);
    match (map.get("constant"), map.get("gradient")) {
        (Some(c), None) => Ok(Sky::Constant {
            radiance: radiance(c, &format!("{at}.constant"))?,
        }),
        (None, Some(g)) => {
            let at = format!("{at}.gradient");
            let gradient = object(g, &at)?;
            warn_unknown(gradient, &["zenith", "horizon", "ground"], &at, warnings);
            let color = |key: &str| match gradient.get(key) {
                Some(v) => radiance(v, &format!("{at}.{key}")),
                None => Err(error(&at, &format!("missing \"{key}\""))),
            };
            Ok(Sky::Gradient {
                zenith: color("zenith")?,
                horizon: color("horizon")?,
                ground: color("ground")?,
            })
        }
        _ => Err(error(
            at,
            "expected exactly one of \"constant\" and \"gradient\"",
        )),
    }
}

fn camera_path(value: &Value, at: &str, warnings: &mut Warnings) -> Result<CameraPath> {
    let map = object(value, at)?;
    warn_unknown(map, &["yfov", "keys"], at, warnings);
    let yfov = match map.get("yfov") {
        Some(v) => number(v, &format!("{at}.yfov"))?,
        None => DEFAULT_PATH_YFOV,
    };
    if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
        return Err(error(
            &format!("{at}.yfov"),
            "expected an angle in (0, pi) radians",
        ));
    }
    let mut keys = Vec::new();
    for (i, key) in required_array(map, "keys", at)?.iter().enumerate() {
        let key_at = format!("{at}.keys[{i}]");
        let fields = object(key, &key_at)?;
        warn_unknown(fields, &["time_s", "position", "target"], &key_at, warnings);
        let field = |name: &str| {
            fields
                .get(name)
                .ok_or_else(|| error(&key_at, &format!("missing \"{name}\"")))
        };
        keys.push(CameraKey {
            time_s: number(field("time_s")?, &format!("{key_at}.time_s"))?,
            position: vec3(field("position")?, &format!("{key_at}.position"))?,
            target: vec3(field("target")?, &format!("{key_at}.target"))?,
        });
    }
    if keys.is_empty() {
        return Err(error(&format!("{at}.keys"), "expected at least one key"));
    }
    let times: Vec<f32> = keys.iter().map(|k| k.time_s).collect();
    strictly_increasing(&times, &format!("{at}.keys"))?;
    Ok(CameraPath { keys, yfov })
}

fn error(at: &str, what: &str) -> Failure {
    unusable(format!("{at}: {what}"))
}

fn warn_unknown(map: &Map<String, Value>, known: &[&str], at: &str, warnings: &mut Warnings) {
    for key in map.keys().filter(|k| !known.contains(&k.as_str())) {
        warnings.once(&format!("{at}.{key}"), || {
            format!("{at}: unknown key \"{key}\" ignored")
        });
    }
}

fn object<'v>(value: &'v Value, at: &str) -> Result<&'v Map<String, Value>> {
    value
        .as_object()
        .ok_or_else(|| error(at, "expected an object"))
}

fn required_array<'v>(map: &'v Map<String, Value>, key: &str, at: &str) -> Result<&'v [Value]> {
    match map.get(key) {
        Some(Value::Array(items)) => Ok(items),
        Some(_) => Err(error(&format!("{at}.{key}"), "expected an array")),
        None => Err(error(at, &format!("missing \"{key}\""))),
    }
}

/// A finite number that fits in f32.
fn number(value: &Value, at: &str) -> Result<f32> {
    value
        .as_f64()
        .filter(|v| v.is_finite() && v.abs() <= f64::from(f32::MAX))
        .map(|v| v as f32)
        .ok_or_else(|| error(at, "expected a number"))
}

fn positive(value: &Value, at: &str) -> Result<f32> {
    let v = number(value, at).map_err(|_| error(at, "expected a positive number"))?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(error(at, "expected a positive number"))
    }
}

fn vec3(value: &Value, at: &str) -> Result<Vec3> {
    match value.as_array().map(Vec::as_slice) {
        Some([x, y, z]) => Ok(Vec3::new(number(x, at)?, number(y, at)?, number(z, at)?)),
        _ => Err(error(at, "expected an array of 3 numbers")),
    }
}

/// Linear RGB radiance: three non-negative numbers.
fn radiance(value: &Value, at: &str) -> Result<Vec3> {
    let rgb = vec3(value, at)?;
    if rgb.min_element() < 0.0 {
        return Err(error(at, "radiance must not be negative"));
    }
    Ok(rgb)
}

fn strictly_increasing(times: &[f32], at: &str) -> Result<()> {
    if times.windows(2).any(|w| w[1] <= w[0]) {
        return Err(error(at, "times must be strictly increasing"));
    }
    Ok(())
}
