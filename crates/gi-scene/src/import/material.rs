//! Metallic-roughness materials and their textures.
//!
//! Materials and textures are imported on first use, so a file's unused materials cost nothing
//! and cannot fail the import. Textures are decoded to linear RGBA: base color, emissive and
//! specular color images are sRGB-encoded and go through the exact sRGB EOTF,
//! metallic-roughness and specular images are already linear. An image used both ways becomes
//! two textures.

use std::borrow::Cow;
use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::io::Cursor;

use glam::{Vec3, Vec4};
use gltf::json;
use gltf::json::material::AlphaMode;
use gltf::json::texture::WrappingMode;
use gltf::json::validation::Checked;
use image::{ImageFormat, ImageReader};

use super::buffers::fetch_uri;
use super::{Result, Source, Warnings, malformed};
use crate::{Material, Scene, Texture, TextureEncoding, TextureRef};

/// Imports materials and textures into a [`Scene`] as primitives ask for them.
pub(super) struct Materials {
    /// Model index of each file material, once imported.
    map: Vec<Option<usize>>,
    /// Model index of the glTF default material, once a primitive needs it.
    default: Option<usize>,
    /// Model texture of each `(image index, sRGB)` pair.
    textures: HashMap<(usize, bool), usize>,
    /// Decoded images before color conversion, by image index.
    images: HashMap<usize, Decoded>,
}

/// An image decoded to RGBA in [0, 1], still in its stored encoding.
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

        match json.alpha_mode {
            Checked::Valid(AlphaMode::Opaque) => {}
            Checked::Valid(AlphaMode::Blend) => warnings.once("alpha-blend", || {
                format!("{label}: alpha mode BLEND is not supported; treated as opaque")
            }),
            Checked::Valid(AlphaMode::Mask) => warnings.once("alpha-mask", || {
                format!("{label}: alpha mode MASK is not supported; treated as opaque")
            }),
            Checked::Invalid => return Err(malformed(format!("{label} has an invalid alphaMode"))),
        }
        if json.normal_texture.is_some() {
            warnings.once("normal-texture", || {
                format!("{label}: normal textures are not supported; ignored")
            });
        }
        if json.occlusion_texture.is_some() {
            warnings.once("occlusion-texture", || {
                format!("{label}: occlusion textures are not supported; ignored")
            });
        }

        let mut texture = |info: &Option<json::texture::Info>, srgb: bool| match info {
            Some(info) => self.texture(source, info, srgb, &label, scene, warnings),
            None => Ok(None),
        };
        let base_color_texture = texture(&pbr.base_color_texture, true)?;
        let metallic_roughness_texture = texture(&pbr.metallic_roughness_texture, false)?;
        let emissive_texture = texture(&json.emissive_texture, true)?;
        let specular_texture = match specular {
            Some(s) => texture(&s.specular_texture, false)?,
            None => None,
        };
        let specular_color_texture = match specular {
            Some(s) => texture(&s.specular_color_texture, true)?,
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
            double_sided: json.double_sided,
            specular: specular_factor.clamp(0.0, 1.0),
            specular_texture,
            specular_color: specular_color.max(Vec3::ZERO),
            specular_color_texture,
            ior,
            ..Material::default()
        })
    }

    /// Model texture for a material's texture reference, decoding its image on first use.
    fn texture(
        &mut self,
        source: &Source,
        info: &json::texture::Info,
        srgb: bool,
        label: &str,
        scene: &mut Scene,
        warnings: &mut Warnings,
    ) -> Result<Option<TextureRef>> {
        if info.tex_coord != 0 {
            warnings.once("texcoord", || {
                format!(
                    "{label}: a texture uses TEXCOORD_{}; only TEXCOORD_0 is supported, so that texture is ignored",
                    info.tex_coord
                )
            });
            return Ok(None);
        }
        let texture_index = info.index.value();
        let texture =
            source.root.textures.get(texture_index).ok_or_else(|| {
                malformed(format!("{label}: texture {texture_index} does not exist"))
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

        let image = texture.source.value();
        if let Some(&model_index) = self.textures.get(&(image, srgb)) {
            return Ok(Some(TextureRef::new(model_index)));
        }
        let decoded = match self.images.entry(image) {
            Entry::Occupied(entry) => entry.into_mut(),
            Entry::Vacant(entry) => entry.insert(decode(source, image)?),
        };
        scene.textures.push(Texture {
            name: decoded.name.clone(),
            width: decoded.width,
            height: decoded.height,
            encoding: if srgb {
                TextureEncoding::Srgb
            } else {
                TextureEncoding::Linear
            },
            texels: decoded.texels.clone(),
        });
        let model_index = scene.textures.len() - 1;
        self.textures.insert((image, srgb), model_index);
        Ok(Some(TextureRef::new(model_index)))
    }
}

/// Decodes image `index` (PNG or JPEG, from a buffer view, a data URI or a file) to RGBA.
fn decode(source: &Source, index: usize) -> Result<Decoded> {
    let label = format!("images[{index}]");
    let image = source
        .root
        .images
        .get(index)
        .ok_or_else(|| malformed(format!("{label} does not exist")))?;
    let bytes: Cow<[u8]> = match (&image.buffer_view, &image.uri) {
        (Some(view), _) => Cow::Borrowed(source.buffers.view(view.value())?),
        (None, Some(uri)) => {
            Cow::Owned(fetch_uri(uri, source.dir).map_err(|e| malformed(format!("{label}: {e}")))?)
        }
        (None, None) => {
            return Err(malformed(format!("{label} has neither uri nor bufferView")));
        }
    };
    let cannot_decode = |e: image::ImageError| malformed(format!("{label}: cannot decode: {e}"));
    let mut reader = ImageReader::new(Cursor::new(&bytes[..]));
    match image.mime_type.as_ref().map(|m| m.0.as_str()) {
        Some("image/png") => reader.set_format(ImageFormat::Png),
        Some("image/jpeg") => reader.set_format(ImageFormat::Jpeg),
        _ => {
            reader = reader
                .with_guessed_format()
                .map_err(|e| cannot_decode(e.into()))?
        }
    }
    let decoded = reader.decode().map_err(cannot_decode)?;
    let (width, height) = (decoded.width(), decoded.height());
    if width == 0 || height == 0 {
        return Err(malformed(format!("{label} is empty")));
    }
    let texels = decoded.into_rgba8().pixels().map(|p| p.0).collect();
    let name = match (&image.name, &image.uri) {
        (Some(name), _) => name.clone(),
        (None, Some(uri)) if !uri.starts_with("data:") => uri.clone(),
        _ => format!("image {index}"),
    };
    Ok(Decoded {
        name,
        width,
        height,
        texels,
    })
}
