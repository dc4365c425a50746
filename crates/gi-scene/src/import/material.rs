//! Metallic-roughness materials and their textures.
//!
//! Materials and textures are imported on first use, so a file's unused materials cost nothing
//! and cannot fail the import. Images are decoded to 8-bit RGBA and keep the encoding of their
//! use: base color, emissive and specular color textures are sRGB-encoded, metallic-roughness,
//! normal, occlusion and specular textures are linear. An image used both ways becomes two
//! textures. An image that cannot be used (missing file, unsupported type, undecodable or larger
//! than [`MAX_IMAGE_SIZE`]) drops the texture references to it with a warning; the material's
//! factors still apply.

use std::borrow::Cow;
use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::io::Cursor;

use glam::{Vec2, Vec3, Vec4};
use gltf::json;
use gltf::json::extensions::texture::TextureTransform as KhrTextureTransform;
use gltf::json::texture::WrappingMode;
use gltf::json::validation::Checked;
use image::{ImageFormat, ImageReader, Limits};

use super::buffers::fetch_uri;
use super::{Result, Source, Warnings, malformed};
use crate::{AlphaMode, Material, Scene, Texture, TextureEncoding, TextureRef, TextureTransform};

/// Imports materials and textures into a [`Scene`] as primitives ask for them.
pub(super) struct Materials {
    /// Model index of each file material, once imported.
    map: Vec<Option<usize>>,
    /// Model index of the glTF default material, once a primitive needs it.
    default: Option<usize>,
    /// Model texture of each `(image index, encoding)` pair.
    textures: HashMap<(usize, TextureEncoding), usize>,
    /// Decoded images by image index, or why the image cannot be used.
    images: HashMap<usize, std::result::Result<Decoded, String>>,
}

/// An image decoded to 8-bit RGBA, still in its stored encoding.
struct Decoded {
    name: String,
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
}

impl Materials {
    /// An importer for a file with `count` materials.
    pub(super) fn new(count: usize) -> Self {
        Self {
            map: vec![None; count],
            default: None,
            textures: HashMap::new(),
            images: HashMap::new(),
        }
    }

    /// Model index of file material `index`, importing it on first use; `None` asks for the
    /// glTF default material (white, metallic 1, roughness 1).
    pub(super) fn resolve(
        &mut self,
        source: &Source,
        index: Option<usize>,
        scene: &mut Scene,
        warnings: &mut Warnings,
    ) -> Result<usize> {
        let Some(index) = index else {
            return Ok(*self.default.get_or_insert_with(|| {
                scene.materials.push(Material::default());
                scene.materials.len() - 1
            }));
        };
        match self.map.get(index) {
            None => Err(malformed(format!("material {index} does not exist"))),
            Some(Some(model_index)) => Ok(*model_index),
            Some(None) => {
                let material = self.import(source, index, scene, warnings)?;
                scene.materials.push(material);
                let model_index = scene.materials.len() - 1;
                self.map[index] = Some(model_index);
                Ok(model_index)
            }
        }
    }

    fn import(
        &mut self,
        source: &Source,
        index: usize,
        scene: &mut Scene,
        warnings: &mut Warnings,
    ) -> Result<Material> {
        let json = &source.root.materials[index];
        let name = json
            .name
            .clone()
            .unwrap_or_else(|| format!("material {index}"));
        let label = format!("materials[{index}] (\"{name}\")");
        let pbr = &json.pbr_metallic_roughness;
        let base_color = Vec4::from(pbr.base_color_factor.0);
        let strength = json
            .extensions
            .as_ref()
            .and_then(|e| e.emissive_strength.as_ref())
            .map_or(1.0, |s| s.emissive_strength.0);
        let emissive_factor = Vec3::from(json.emissive_factor.0);
        let (metallic, roughness) = (pbr.metallic_factor.0, pbr.roughness_factor.0);
        let specular = json.extensions.as_ref().and_then(|e| e.specular.as_ref());
        let specular_factor = specular.map_or(1.0, |s| s.specular_factor.0);
        let specular_color = specular.map_or(Vec3::ONE, |s| Vec3::from(s.specular_color_factor.0));
        let ior = json
            .extensions
            .as_ref()
            .and_then(|e| e.ior.as_ref())
            .map_or(1.5, |i| i.ior.0);
        if !(base_color.is_finite()
            && emissive_factor.is_finite()
            && metallic.is_finite()
            && roughness.is_finite()
            && strength.is_finite()
            && specular_factor.is_finite()
            && specular_color.is_finite()
            && ior.is_finite())
        {
            return Err(malformed(format!("{label} has non-finite factors")));
        }
        if strength < 0.0 || emissive_factor.min_element() < 0.0 {
            return Err(malformed(format!("{label} has a negative emissive value")));
        }
        // KHR_materials_ior allows 1 and above, and 0; other values would make up a Fresnel
        // reflectance the extension does not define.
        if ior < 0.0 || (ior > 0.0 && ior < 1.0) {
            return Err(malformed(format!(
                "{label} has ior {ior}; KHR_materials_ior allows 0 or at least 1"
            )));
        }

        let alpha_mode = match json.alpha_mode {
            Checked::Valid(json::material::AlphaMode::Opaque) => AlphaMode::Opaque,
            Checked::Valid(json::material::AlphaMode::Blend) => AlphaMode::Blend,
            Checked::Valid(json::material::AlphaMode::Mask) => {
                let cutoff = json.alpha_cutoff.map_or(0.5, |c| c.0);
                if !cutoff.is_finite() {
                    return Err(malformed(format!("{label} has a non-finite alphaCutoff")));
                }
                AlphaMode::Mask { cutoff }
            }
            Checked::Invalid => return Err(malformed(format!("{label} has an invalid alphaMode"))),
        };
        let normal_scale = json.normal_texture.as_ref().map_or(1.0, |t| t.scale);
        let occlusion_strength = json
            .occlusion_texture
            .as_ref()
            .map_or(1.0, |t| t.strength.0);
        if !(normal_scale.is_finite() && occlusion_strength.is_finite()) {
            return Err(malformed(format!(
                "{label} has a non-finite normal scale or occlusion strength"
            )));
        }

        let mut texture = |slot: Option<Slot>, encoding: TextureEncoding| match slot {
            Some(slot) => self.texture(source, &slot, encoding, &label, scene, warnings),
            None => Ok(None),
        };
        use TextureEncoding::{Linear, Srgb};
        let info = |name: &'static str, info: &Option<json::texture::Info>| {
            info.as_ref().map(|i| Slot::from_info(name, i))
        };
        let base_color_texture = texture(info("baseColorTexture", &pbr.base_color_texture), Srgb)?;
        let metallic_roughness_texture = texture(
            info("metallicRoughnessTexture", &pbr.metallic_roughness_texture),
            Linear,
        )?;
        let emissive_texture = texture(info("emissiveTexture", &json.emissive_texture), Srgb)?;
        let normal_texture = match &json.normal_texture {
            Some(t) => texture(
                Some(Slot::new(
                    "normalTexture",
                    t.index.value(),
                    t.tex_coord,
                    t.extensions.as_ref().map(|e| &e.others),
                )?),
                Linear,
            )?,
            None => None,
        };
        let occlusion_texture = match &json.occlusion_texture {
            Some(t) => texture(
                Some(Slot::new(
                    "occlusionTexture",
                    t.index.value(),
                    t.tex_coord,
                    t.extensions.as_ref().map(|e| &e.others),
                )?),
                Linear,
            )?,
            None => None,
        };
        let specular_texture = match specular {
            Some(s) => texture(info("specularTexture", &s.specular_texture), Linear)?,
            None => None,
        };
        let specular_color_texture = match specular {
            Some(s) => texture(
                info("specularColorTexture", &s.specular_color_texture),
                Srgb,
            )?,
            None => None,
        };

        // Factors outside the glTF ranges would break the BRDF's energy bounds.
        Ok(Material {
            name,
            base_color: base_color.clamp(Vec4::ZERO, Vec4::ONE),
            base_color_texture,
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            metallic_roughness_texture,
            emissive: emissive_factor * strength,
            emissive_texture,
            normal_texture,
            normal_scale,
            occlusion_texture,
            occlusion_strength: occlusion_strength.clamp(0.0, 1.0),
            alpha_mode,
            double_sided: json.double_sided,
            specular: specular_factor.clamp(0.0, 1.0),
            specular_texture,
            specular_color: specular_color.max(Vec3::ZERO),
            specular_color_texture,
            ior,
        })
    }

    /// Model texture for a material's texture slot, decoding its image on first use. A slot
    /// whose image is missing, undecodable or too large is dropped with a warning.
    fn texture(
        &mut self,
        source: &Source,
        slot: &Slot,
        encoding: TextureEncoding,
        label: &str,
        scene: &mut Scene,
        warnings: &mut Warnings,
    ) -> Result<Option<TextureRef>> {
        let slot_label = format!("{label}.{}", slot.name);
        if slot.tex_coord > 1 {
            warnings.once(&format!("texcoord-{}", slot.tex_coord), || {
                format!(
                    "{slot_label}: uses TEXCOORD_{}; only TEXCOORD_0 and TEXCOORD_1 are supported, so that texture is dropped",
                    slot.tex_coord
                )
            });
            return Ok(None);
        }
        let texture_index = slot.texture;
        let texture = source.root.textures.get(texture_index).ok_or_else(|| {
            malformed(format!(
                "{slot_label}: texture {texture_index} does not exist"
            ))
        })?;
        if let Some(sampler) = texture.sampler {
            let sampler = source.root.samplers.get(sampler.value()).ok_or_else(|| {
                malformed(format!("textures[{texture_index}]: sampler does not exist"))
            })?;
            for wrap in [sampler.wrap_s, sampler.wrap_t] {
                let mode = match wrap {
                    Checked::Valid(WrappingMode::Repeat) => continue,
                    Checked::Valid(WrappingMode::ClampToEdge) => "CLAMP_TO_EDGE",
                    Checked::Valid(WrappingMode::MirroredRepeat) => "MIRRORED_REPEAT",
                    Checked::Invalid => {
                        return Err(malformed(format!(
                            "textures[{texture_index}]: invalid sampler wrap mode"
                        )));
                    }
                };
                warnings.once("wrap-mode", || {
                    format!("textures[{texture_index}]: wrap mode {mode} is not supported; textures always repeat")
                });
            }
        }

        // With the `allow_empty_texture` parse, a texture without a core `source` holds
        // `u32::MAX`, which no image list reaches.
        let image = texture.source.value();
        if image >= source.root.images.len() {
            let others = texture.extensions.as_ref().map(|e| &e.others);
            let alternatives: Vec<&str> = others
                .into_iter()
                .flat_map(|o| o.keys())
                .map(String::as_str)
                .collect();
            let why = if alternatives.is_empty() {
                "has no image source".to_string()
            } else {
                format!(
                    "has only a {} source, which is not read",
                    alternatives.join("/")
                )
            };
            warnings.once(&format!("no-source-{texture_index}"), || {
                format!("{slot_label}: textures[{texture_index}] {why}; the texture is dropped and the material's factor applies")
            });
            return Ok(None);
        }

        let model_index = match self.textures.get(&(image, encoding)) {
            Some(&model_index) => model_index,
            None => {
                let decoded = match self.images.entry(image) {
                    Entry::Occupied(entry) => entry.into_mut(),
                    Entry::Vacant(entry) => entry.insert(decode(source, image)?),
                };
                let decoded = match decoded {
                    Ok(decoded) => decoded,
                    Err(problem) => {
                        let problem = problem.clone();
                        warnings.once(&format!("image-{image}-{slot_label}"), || {
                            format!("{slot_label}: {problem}; the texture is dropped and the material's factor applies")
                        });
                        return Ok(None);
                    }
                };
                scene.textures.push(Texture {
                    name: decoded.name.clone(),
                    width: decoded.width,
                    height: decoded.height,
                    encoding,
                    texels: decoded.texels.clone(),
                });
                let model_index = scene.textures.len() - 1;
                self.textures.insert((image, encoding), model_index);
                model_index
            }
        };
        Ok(Some(TextureRef {
            texture: model_index,
            tex_coord: slot.tex_coord,
            transform: slot.transform,
        }))
    }
}

/// A material's texture slot, whichever glTF type (`textureInfo`, `normalTextureInfo`,
/// `occlusionTextureInfo`) it came from, with `KHR_texture_transform` applied.
struct Slot {
    /// The glTF property name, for warnings.
    name: &'static str,
    texture: usize,
    /// The texture coordinate set, after the transform's `texCoord` override.
    tex_coord: u32,
    transform: TextureTransform,
}

impl Slot {
    fn from_info(name: &'static str, info: &json::texture::Info) -> Self {
        let transform = info
            .extensions
            .as_ref()
            .and_then(|e| e.texture_transform.as_ref());
        Self::with_transform(name, info.index.value(), info.tex_coord, transform)
    }

    /// A slot whose extensions are still an untyped map (normal and occlusion textures).
    fn new(
        name: &'static str,
        texture: usize,
        tex_coord: u32,
        extensions: Option<&serde_json::Map<String, serde_json::Value>>,
    ) -> Result<Self> {
        let transform = match extensions.and_then(|e| e.get("KHR_texture_transform")) {
            Some(value) => Some(
                serde_json::from_value::<KhrTextureTransform>(value.clone()).map_err(|e| {
                    malformed(format!("{name}: invalid KHR_texture_transform: {e}"))
                })?,
            ),
            None => None,
        };
        Ok(Self::with_transform(
            name,
            texture,
            tex_coord,
            transform.as_ref(),
        ))
    }

    fn with_transform(
        name: &'static str,
        texture: usize,
        tex_coord: u32,
        transform: Option<&KhrTextureTransform>,
    ) -> Self {
        let Some(t) = transform else {
            return Self {
                name,
                texture,
                tex_coord,
                transform: TextureTransform::IDENTITY,
            };
        };
        let transform = TextureTransform {
            offset: Vec2::from(t.offset.0),
            rotation: t.rotation.0,
            scale: Vec2::from(t.scale.0),
        };
        // Non-finite values would poison every texture coordinate: the identity stands in.
        let finite = transform.offset.is_finite()
            && transform.rotation.is_finite()
            && transform.scale.is_finite();
        Self {
            name,
            texture,
            tex_coord: t.tex_coord.unwrap_or(tex_coord),
            transform: if finite {
                transform
            } else {
                TextureTransform::IDENTITY
            },
        }
    }
}

/// Largest width and height of an image the importer decodes; larger images are refused
/// before decoding, which bounds one image's memory to 256 MiB of RGBA8.
const MAX_IMAGE_SIZE: u32 = 8192;

/// Decodes image `index` (PNG or JPEG, from a buffer view, a data URI or a file) to RGBA.
/// `Err` holds a description of why the image cannot be used (missing file, unsupported type,
/// undecodable or too large data), for the warning of each slot that uses it; a broken
/// document (no such image) is an import error.
fn decode(source: &Source, index: usize) -> Result<std::result::Result<Decoded, String>> {
    let image = source
        .root
        .images
        .get(index)
        .ok_or_else(|| malformed(format!("images[{index}] does not exist")))?;
    let name = match (&image.name, &image.uri) {
        (Some(name), _) => name.clone(),
        (None, Some(uri)) if !uri.starts_with("data:") => uri.clone(),
        _ => format!("image {index}"),
    };
    let label = format!("images[{index}] (\"{name}\")");
    let bytes: Cow<[u8]> = match (&image.buffer_view, &image.uri) {
        (Some(view), _) => match source.buffers.view(view.value()) {
            Ok(bytes) => Cow::Borrowed(bytes),
            Err(_) => return Ok(Err(format!("{label}: its buffer view is unreadable"))),
        },
        (None, Some(uri)) => match fetch_uri(uri, source.dir) {
            Ok(bytes) => Cow::Owned(bytes),
            Err(e) => return Ok(Err(format!("{label} cannot be read: {e}"))),
        },
        (None, None) => return Ok(Err(format!("{label} has neither uri nor bufferView"))),
    };
    let mut reader = ImageReader::new(Cursor::new(&bytes[..]));
    match image.mime_type.as_ref().map(|m| m.0.as_str()) {
        Some("image/png") => reader.set_format(ImageFormat::Png),
        Some("image/jpeg") => reader.set_format(ImageFormat::Jpeg),
        Some(other) => {
            return Ok(Err(format!(
                "{label} has mime type {other}; only image/png and image/jpeg are read"
            )));
        }
        None => match reader.with_guessed_format() {
            Ok(guessed) => reader = guessed,
            Err(e) => return Ok(Err(format!("{label} cannot be read: {e}"))),
        },
    }
    if !matches!(reader.format(), Some(ImageFormat::Png | ImageFormat::Jpeg)) {
        return Ok(Err(format!("{label} is neither PNG nor JPEG")));
    }
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIZE);
    limits.max_image_height = Some(MAX_IMAGE_SIZE);
    reader.limits(limits);
    let decoded = match reader.decode() {
        Ok(decoded) => decoded,
        Err(image::ImageError::Limits(_)) => {
            return Ok(Err(format!(
                "{label} is larger than {MAX_IMAGE_SIZE} x {MAX_IMAGE_SIZE} texels and is not decoded"
            )));
        }
        Err(e) => return Ok(Err(format!("{label} cannot be decoded: {e}"))),
    };
    let (width, height) = (decoded.width(), decoded.height());
    if width == 0 || height == 0 {
        return Ok(Err(format!("{label} is empty")));
    }
    let texels = decoded.into_rgba8().pixels().map(|p| p.0).collect();
    Ok(Ok(Decoded {
        name,
        width,
        height,
        texels,
    }))
}
