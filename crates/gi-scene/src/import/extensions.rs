//! What the importer does with each glTF extension a file uses or requires.
//!
//! Three kinds: extensions the importer reads; extensions it ignores while the file still loads,
//! with a warning saying what is lost (material extensions only change the look, and unread
//! alternative texture sources have a core fallback or drop one texture); and extensions that change
//! geometry in a way the importer cannot decode, which refuse a file that requires them.

use gltf::json;

use super::{Result, Warnings, unusable};

/// How the importer treats one extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Support {
    /// Read in full.
    Supported,
    /// Ignored: the file loads with a warning; the text says what is lost.
    Warned(&'static str),
    /// Cannot be decoded: a file that requires it is refused; the text says why.
    Refused(&'static str),
}

use Support::{Refused, Supported, Warned};

/// Every extension the importer knows about. Unknown `KHR_materials_*` extensions are
/// [`Support::Warned`] like the listed ones; other unknown extensions are warned when used
/// and refused when required.
const EXTENSIONS: &[(&str, Support)] = &[
    ("KHR_lights_punctual", Supported),
    ("KHR_materials_emissive_strength", Supported),
    ("KHR_materials_ior", Supported),
    ("KHR_materials_specular", Supported),
    ("KHR_mesh_quantization", Supported),
    ("KHR_texture_transform", Supported),
    // DDS sources are decoded (`super::dds`): BC1-BC7 (BC6H clamped to [0, 1]), R8G8B8A8,
    // B8G8R8A8/X8 and legacy masked formats, mip level 0 of the first 2D surface. A texture
    // reads its core `source` when that decodes, else its DDS source.
    ("MSFT_texture_dds", Supported),
    // Separate roughness and metallic maps, combined into a metallic-roughness texture when
    // the material has no usable core one (`Textures::split_metallic_roughness`).
    ("AMD_split_roughnessMetallic", Supported),
    (
        "KHR_materials_clearcoat",
        Warned("clearcoat layers are not rendered"),
    ),
    (
        "KHR_materials_sheen",
        Warned("sheen layers are not rendered"),
    ),
    (
        "KHR_materials_transmission",
        Warned("transmission is not rendered: transmissive surfaces are opaque"),
    ),
    (
        "KHR_materials_volume",
        Warned("volume absorption is not rendered"),
    ),
    (
        "KHR_materials_variants",
        Warned("material variants are not selectable: each primitive keeps its default material"),
    ),
    (
        "KHR_materials_iridescence",
        Warned("iridescence is not rendered"),
    ),
    (
        "KHR_materials_anisotropy",
        Warned("anisotropic highlights are rendered isotropic"),
    ),
    (
        "KHR_materials_dispersion",
        Warned("dispersion is not rendered"),
    ),
    (
        "KHR_materials_unlit",
        Warned("unlit materials are shaded as lit metallic-roughness materials"),
    ),
    (
        "KHR_materials_pbrSpecularGlossiness",
        Warned(
            "specular-glossiness parameters are not read: materials use their metallic-roughness fallback",
        ),
    ),
    (
        "KHR_texture_basisu",
        Warned(
            "KTX2 texture sources are not read: textures use their core source, and a texture with only a KTX2 source is dropped",
        ),
    ),
    (
        "EXT_texture_webp",
        Warned(
            "WebP texture sources are not read: textures use their core source, and a texture with only a WebP source is dropped",
        ),
    ),
    (
        "KHR_draco_mesh_compression",
        Refused("Draco-compressed meshes cannot be decoded"),
    ),
    (
        "EXT_meshopt_compression",
        Refused("meshopt-compressed buffers cannot be decoded"),
    ),
    (
        "KHR_meshopt_compression",
        Refused("meshopt-compressed buffers cannot be decoded"),
    ),
];

/// How the importer treats extension `name`; `None` for an unknown extension that is not a
/// material extension.
pub(super) fn support(name: &str) -> Option<Support> {
    match EXTENSIONS.iter().find(|(n, _)| *n == name) {
        Some(&(_, support)) => Some(support),
        None if name.starts_with("KHR_materials_") => Some(Warned(
            "this material extension is not rendered; the metallic-roughness core applies",
        )),
        None => None,
    }
}

/// Fails when the file requires an extension the importer cannot decode.
pub(super) fn check_required(root: &json::Root) -> Result<()> {
    for ext in &root.extensions_required {
        let why = match support(ext) {
            Some(Refused(why)) => why,
            None => "the importer does not know it",
            Some(Supported | Warned(_)) => continue,
        };
        return Err(unusable(format!(
            "the file requires extension {ext}, which is not supported: {why}"
        )));
    }
    Ok(())
}

/// One warning per used or required extension that the importer does not read.
pub(super) fn warn_ignored(root: &json::Root, warnings: &mut Warnings) {
    let required = |ext: &String| root.extensions_required.contains(ext);
    let listed = root
        .extensions_required
        .iter()
        .chain(root.extensions_used.iter().filter(|e| !required(e)));
    for ext in listed {
        let message = match support(ext) {
            Some(Supported) => continue,
            Some(Warned(lost)) if required(ext) => format!(
                "the file requires extension {ext}, which is not supported; it loads without it: {lost}"
            ),
            Some(Warned(lost)) => format!("extension {ext} is not supported: {lost}"),
            // A file that uses a compression extension without requiring it keeps uncompressed
            // fallback data.
            Some(Refused(why)) => format!(
                "extension {ext} is not supported ({why}); the uncompressed fallback data is used"
            ),
            None => format!("extension {ext} is not supported and is ignored"),
        };
        warnings.once(ext, || message);
    }
}
