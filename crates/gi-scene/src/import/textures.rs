//! Material texture slots: which image a texture reads, the model texture made of it for the
//! slot's role, and the metallic-roughness texture combined from `AMD_split_roughnessMetallic`'s
//! separate maps.
//!
//! A texture reads its core `source` when that image decodes, else its `MSFT_texture_dds`
//! source. A texture with neither usable (missing file, unsupported type, undecodable,
//! truncated or larger than [`MAX_IMAGE_SIZE`](super::images::MAX_IMAGE_SIZE)) is dropped from
//! the slot with a warning naming the images and why; the material's factor still applies.

use std::collections::HashMap;
use std::collections::hash_map::Entry;

use glam::Vec2;
use gltf::json;
use gltf::json::extensions::texture::TextureTransform as KhrTextureTransform;
use gltf::json::texture::WrappingMode;
use gltf::json::validation::Checked;

use super::images::{self, Decoded, Role};
use super::{Result, Source, Warnings, malformed};
use crate::{Scene, Texture, TextureEncoding, TextureRef, TextureTransform};

/// Decoded images and the model textures made of them, shared by all materials of a file.
#[derive(Default)]
pub(super) struct Textures {
    /// Decoded images by image index, or why the image cannot be used.
    images: HashMap<usize, std::result::Result<Decoded, String>>,
    /// Model texture of each `(image index, role variant)` pair.
    made: HashMap<(usize, Role), usize>,
    /// Model texture combined from each `(roughness image, metallic image)` pair.
    combined: HashMap<(Option<usize>, Option<usize>), usize>,
}

impl Textures {
    /// Model texture for a material's texture slot read in `role`, decoding its image on first
    /// use; `None`, with a warning, when the slot has no usable image. `label` names the
    /// material in warnings.
    pub(super) fn slot(
        &mut self,
        source: &Source,
        slot: &Slot,
        role: Role,
        label: &str,
        scene: &mut Scene,
        warnings: &mut Warnings,
    ) -> Result<Option<TextureRef>> {
        let Some(image) = self.usable_image(source, slot, label, warnings)? else {
            return Ok(None);
        };
        let Some(Ok(decoded)) = self.images.get(&image) else {
            return Ok(None);
        };
        let variant = decoded.variant(role);
        let model_index = match self.made.entry((image, variant)) {
            Entry::Occupied(entry) => *entry.get(),
            Entry::Vacant(entry) => {
                scene.textures.push(Texture {
                    name: decoded.name.clone(),
                    width: decoded.width,
                    height: decoded.height,
                    encoding: role.encoding(),
                    texels: decoded.texels(variant),
                });
                *entry.insert(scene.textures.len() - 1)
            }
        };
        Ok(Some(slot.reference(model_index)))
    }

    /// The metallic-roughness texture combined from `AMD_split_roughnessMetallic`'s separate
    /// maps: roughness into green and metallic into blue (each read from its map's red channel;
    /// a one-channel map such as BC4 decodes to grey), red and alpha 1. A map that is absent or
    /// cannot be used (warned) leaves its channel at 1, so the material's factor applies
    /// unscaled. Maps of different sizes are combined at the larger width and height, nearest
    /// texel. The texture takes the roughness slot's texture coordinates and transform (the
    /// metallic slot's without a roughness map), with a warning when the two differ.
    pub(super) fn split_metallic_roughness(
        &mut self,
        source: &Source,
        roughness: Option<&Slot>,
        metallic: Option<&Slot>,
        label: &str,
        scene: &mut Scene,
        warnings: &mut Warnings,
    ) -> Result<Option<TextureRef>> {
        let mut image_of = |slot: Option<&Slot>| match slot {
            Some(slot) => self.usable_image(source, slot, label, warnings),
            None => Ok(None),
        };
        let roughness_image = image_of(roughness)?;
        let metallic_image = image_of(metallic)?;
        let used: Vec<&Slot> = [(roughness, roughness_image), (metallic, metallic_image)]
            .into_iter()
            .filter_map(|(slot, image)| image.and(slot))
            .collect();
        let Some(&first) = used.first() else {
            return Ok(None);
        };
        if let Some(&second) = used.get(1)
            && (second.tex_coord, second.transform) != (first.tex_coord, first.transform)
        {
            warnings.once(&format!("split-coordinates-{label}"), || {
                format!("{label}: AMD_split_roughnessMetallic's metallicTexture uses other texture coordinates than its roughnessTexture; the combined texture uses the roughness map's")
            });
        }

        let key = (roughness_image, metallic_image);
        let model_index = match self.combined.get(&key) {
            Some(&model_index) => model_index,
            None => {
                let decoded = |image: Option<usize>| {
                    image
                        .and_then(|i| self.images.get(&i))
                        .and_then(|d| d.as_ref().ok())
                };
                let (roughness, metallic) = (decoded(roughness_image), decoded(metallic_image));
                if let Some(budget) = &source.texel_budget {
                    let (width, height) = combined_size(roughness, metallic);
                    budget.charge(width, height, || {
                        format!("{label}: the metallic-roughness texture combined from AMD_split_roughnessMetallic's maps ({width} x {height} texels)")
                    })?;
                }
                let texture = combine_split_maps(roughness, metallic);
                scene.textures.push(texture);
                self.combined.insert(key, scene.textures.len() - 1);
                scene.textures.len() - 1
            }
        };
        Ok(Some(first.reference(model_index)))
    }

    /// The image slot `slot` reads, decoded and usable: the texture's core source when it
    /// decodes, else its `MSFT_texture_dds` source. `None`, with a warning, when the slot cannot
    /// be used (an unsupported texture coordinate set) or no source decodes.
    fn usable_image(
        &mut self,
        source: &Source,
        slot: &Slot,
        label: &str,
        warnings: &mut Warnings,
    ) -> Result<Option<usize>> {
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
            warn_wrap_modes(source, sampler.value(), texture_index, warnings)?;
        }

        let others = texture.extensions.as_ref().map(|e| &e.others);
        let dds = match others.and_then(|o| o.get("MSFT_texture_dds")) {
            Some(extension) => Some(dds_source(source, extension, texture_index)?),
            None => None,
        };
        // With the `allow_empty_texture` parse, a texture without a core `source` holds
        // `u32::MAX`, which no image list reaches.
        let core = Some(texture.source.value()).filter(|&i| i < source.root.images.len());
        let mut problems = Vec::new();
        for image in [core, dds].into_iter().flatten() {
            let decoded = match self.images.entry(image) {
                Entry::Occupied(entry) => entry.into_mut(),
                Entry::Vacant(entry) => entry.insert(images::decode(source, image)?),
            };
            match decoded {
                Ok(decoded) => {
                    if !problems.is_empty() {
                        let problems = problems.join("; ");
                        warnings.once(&format!("fallback-{texture_index}-{slot_label}"), || {
                            format!("{slot_label}: {problems}; textures[{texture_index}]'s MSFT_texture_dds source images[{image}] is used instead")
                        });
                    }
                    if !decoded.notes.is_empty() {
                        let notes = decoded.notes.join("; ");
                        warnings.once(&format!("image-notes-{image}"), || {
                            format!("{slot_label}: {notes}")
                        });
                    }
                    return Ok(Some(image));
                }
                Err(problem) => problems.push(problem.clone()),
            }
        }

        let unread: Vec<&str> = others
            .into_iter()
            .flat_map(|o| o.keys())
            .map(String::as_str)
            .filter(|&name| name != "MSFT_texture_dds")
            .collect();
        let why = match (problems.is_empty(), unread.is_empty()) {
            (true, true) => format!("textures[{texture_index}] has no image source"),
            (true, false) => format!(
                "textures[{texture_index}] has only a {} source, which is not read",
                unread.join("/")
            ),
            (false, true) => problems.join("; "),
            (false, false) => format!(
                "{} (its {} source is not read)",
                problems.join("; "),
                unread.join("/")
            ),
        };
        warnings.grouped(
            "the texture is dropped and the material's factor applies",
            &format!("no-image-{texture_index}-{slot_label}"),
            || format!("{slot_label}: {why}"),
        );
        Ok(None)
    }
}

/// Warns once about sampler wrap modes other than `REPEAT`, which the tiers do not have.
fn warn_wrap_modes(
    source: &Source,
    sampler: usize,
    texture_index: usize,
    warnings: &mut Warnings,
) -> Result<()> {
    let sampler =
        source.root.samplers.get(sampler).ok_or_else(|| {
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
    Ok(())
}

/// The image index `MSFT_texture_dds` extension value `extension` names; a missing or
/// out-of-range index is a broken document.
fn dds_source(
    source: &Source,
    extension: &serde_json::Value,
    texture_index: usize,
) -> Result<usize> {
    let index = extension
        .get("source")
        .and_then(serde_json::Value::as_u64)
        .ok_or_else(|| {
            malformed(format!(
                "textures[{texture_index}]: MSFT_texture_dds has no image index as its source"
            ))
        })?;
    usize::try_from(index)
        .ok()
        .filter(|&i| i < source.root.images.len())
        .ok_or_else(|| {
            malformed(format!(
                "textures[{texture_index}]: MSFT_texture_dds source {index} does not exist"
            ))
        })
}

/// The size of the texture combined from `roughness` and `metallic`: the larger width and the
/// larger height.
fn combined_size(roughness: Option<&Decoded>, metallic: Option<&Decoded>) -> (u32, u32) {
    let size = |d: Option<&Decoded>| d.map_or((0, 0), |d| (d.width, d.height));
    let (r, m) = (size(roughness), size(metallic));
    (r.0.max(m.0), r.1.max(m.1))
}

/// A metallic-roughness texture of `roughness`'s red channel in green and `metallic`'s red in
/// blue (1 where a map is absent), at the larger of the two sizes; see
/// [`Textures::split_metallic_roughness`].
fn combine_split_maps(roughness: Option<&Decoded>, metallic: Option<&Decoded>) -> Texture {
    let (width, height) = combined_size(roughness, metallic);
    let maps = [roughness, metallic].map(|d| d.map(|d| (d, d.texels(Role::Data))));
    let channel = |map: &Option<(&Decoded, Vec<[u8; 4]>)>, x: u32, y: u32| match map {
        Some((d, texels)) => {
            let sx = u64::from(x) * u64::from(d.width) / u64::from(width);
            let sy = u64::from(y) * u64::from(d.height) / u64::from(height);
            texels[(sy * u64::from(d.width) + sx) as usize][0]
        }
        None => 255,
    };
    let texels = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| [255, channel(&maps[0], x, y), channel(&maps[1], x, y), 255])
        .collect();
    let name = [roughness, metallic]
        .into_iter()
        .flatten()
        .map(|d| d.name.as_str())
        .collect::<Vec<_>>()
        .join(" + ");
    Texture {
        name,
        width,
        height,
        encoding: TextureEncoding::Linear,
        texels,
    }
}

/// A material's texture slot, whichever glTF type (`textureInfo`, `normalTextureInfo`,
/// `occlusionTextureInfo`) it came from, with `KHR_texture_transform` applied.
pub(super) struct Slot {
    /// The glTF property name, for warnings.
    name: &'static str,
    texture: usize,
    /// The texture coordinate set, after the transform's `texCoord` override.
    tex_coord: u32,
    transform: TextureTransform,
}

impl Slot {
    /// A reference to model texture `texture` with this slot's coordinates and transform.
    fn reference(&self, texture: usize) -> TextureRef {
        TextureRef {
            texture,
            tex_coord: self.tex_coord,
            transform: self.transform,
        }
    }

    pub(super) fn from_info(name: &'static str, info: &json::texture::Info) -> Self {
        let transform = info
            .extensions
            .as_ref()
            .and_then(|e| e.texture_transform.as_ref());
        Self::with_transform(name, info.index.value(), info.tex_coord, transform)
    }

    /// A slot whose extensions are still an untyped map (normal and occlusion textures).
    pub(super) fn new(
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
