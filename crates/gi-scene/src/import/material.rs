//! Metallic-roughness materials.
//!
//! Materials and textures are imported on first use, so a file's unused materials cost nothing
//! and cannot fail the import. Images are decoded to 8-bit RGBA and keep the encoding of their
//! use: base color, emissive and specular color textures are sRGB-encoded, metallic-roughness,
//! normal, occlusion and specular textures are linear. An image used both ways becomes two
//! textures. Which image a texture reads, and what happens when none can be used, is
//! [`super::textures`]'s business; the material's factors apply whatever the textures.
//!
//! `AMD_split_roughnessMetallic` gives roughness and metallic as separate maps; when the
//! material has no usable core `metallicRoughnessTexture` they are combined into one (see
//! [`Textures::split_metallic_roughness`]).

use glam::{Vec3, Vec4};
use gltf::json;
use gltf::json::validation::Checked;
use serde::Deserialize;

use super::images::Role;
use super::textures::{Slot, Textures};
use super::{Result, Source, Warnings, malformed};
use crate::{AlphaMode, Material, Scene};

/// Imports materials and textures into a [`Scene`] as primitives ask for them.
pub(super) struct Materials {
    /// Model index of each file material, once imported.
    map: Vec<Option<usize>>,
    /// Model index of the glTF default material, once a primitive needs it.
    default: Option<usize>,
    /// Decoded images and the model textures made of them.
    textures: Textures,
}

/// The `AMD_split_roughnessMetallic` material extension.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct SplitRoughnessMetallic {
    roughness_texture: Option<json::texture::Info>,
    metallic_texture: Option<json::texture::Info>,
}

impl Materials {
    /// An importer for a file with `count` materials.
    pub(super) fn new(count: usize) -> Self {
        Self {
            map: vec![None; count],
            default: None,
            textures: Textures::default(),
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

        let split = match json
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("AMD_split_roughnessMetallic"))
        {
            Some(value) => Some(
                serde_json::from_value::<SplitRoughnessMetallic>(value.clone()).map_err(|e| {
                    malformed(format!("{label}: invalid AMD_split_roughnessMetallic: {e}"))
                })?,
            ),
            None => None,
        };

        let textures = &mut self.textures;
        let mut texture = |slot: Option<Slot>, role: Role| match slot {
            Some(slot) => textures.slot(source, &slot, role, &label, scene, warnings),
            None => Ok(None),
        };
        let info = |name: &'static str, info: &Option<json::texture::Info>| {
            info.as_ref().map(|i| Slot::from_info(name, i))
        };
        let base_color_texture = texture(
            info("baseColorTexture", &pbr.base_color_texture),
            Role::Color,
        )?;
        let mut metallic_roughness_texture = texture(
            info("metallicRoughnessTexture", &pbr.metallic_roughness_texture),
            Role::Data,
        )?;
        let emissive_texture =
            texture(info("emissiveTexture", &json.emissive_texture), Role::Color)?;
        let normal_texture = match &json.normal_texture {
            Some(t) => texture(
                Some(Slot::new(
                    "normalTexture",
                    t.index.value(),
                    t.tex_coord,
                    t.extensions.as_ref().map(|e| &e.others),
                )?),
                Role::Normal,
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
                Role::Data,
            )?,
            None => None,
        };
        let specular_texture = match specular {
            Some(s) => texture(info("specularTexture", &s.specular_texture), Role::Data)?,
            None => None,
        };
        let specular_color_texture = match specular {
            Some(s) => texture(
                info("specularColorTexture", &s.specular_color_texture),
                Role::Color,
            )?,
            None => None,
        };
        if let (None, Some(split)) = (metallic_roughness_texture, split) {
            let roughness = info(
                "AMD_split_roughnessMetallic.roughnessTexture",
                &split.roughness_texture,
            );
            let metallic = info(
                "AMD_split_roughnessMetallic.metallicTexture",
                &split.metallic_texture,
            );
            metallic_roughness_texture = self.textures.split_metallic_roughness(
                source,
                roughness.as_ref(),
                metallic.as_ref(),
                &label,
                scene,
                warnings,
            )?;
        }

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
}
