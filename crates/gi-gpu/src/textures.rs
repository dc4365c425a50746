//! A scene's textures on the GPU: 8-bit RGBA texture arrays with full mip chains, one array per
//! size class and encoding, a trilinear repeating sampler, and the table of texture references
//! the materials index.
//!
//! Every texture of the scene becomes one layer of a square power-of-two `Rgba8Unorm` array of
//! side 64..=2048 ([`TEXTURE_SIZES`]): six arrays in bind group [`TEXTURE_BIND_GROUP`],
//! whatever the scene, so every pass has the same layout. Texels keep their stored 8-bit
//! values; the shader decodes sRGB-encoded ones with the exact sRGB EOTF after loading, as the
//! CPU does (hardware sRGB formats may approximate the curve), so level-0 reads give the
//! reference's values. Trilinear filtering of minified sRGB textures then interpolates encoded
//! values before decoding, a small error within a prefiltered footprint.
//!
//! - A power-of-two texture smaller than its layer, or not square, is tiled across the layer and
//!   its reference scales the texture coordinate by the tiling: texel `(x, y)` of the layer is
//!   texel `(x mod w, y mod h)` of the texture, so bilinear filtering with repeat wrapping reads
//!   exactly the texture's texels, at every mip level.
//! - Other sizes are resampled (bilinear, in linear values) to the next power of two first; the
//!   GPU then samples a slightly different image than the CPU reference does.
//! - Mip levels are 2x2 box filters of the linear values.
//! - The scene's textures must fit [`TextureOptions::budget_bytes`]: over it, the largest
//!   textures lose their top mip level until they fit, with a warning. A texture larger than
//!   [`TextureOptions::max_size`] starts at the mip level that fits.
//!
//! The WGSL side is `gi::scene` (`shaders/path/scene.wgsl`): `sample_texture` reads level 0
//! with the reference's own bilinear filter (exact texel loads), `sample_texture_lod` filters
//! trilinearly at a level of detail from a ray cone.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use gi_scene::{Scene, Texture, TextureEncoding, TextureRef};
use glam::Vec4;
use rayon::prelude::*;
use thiserror::Error;

use crate::GpuContext;

/// The bind group of the texture arrays and their sampler.
pub const TEXTURE_BIND_GROUP: u32 = 3;

/// Side of the layers of each size class, smallest first.
pub const TEXTURE_SIZES: [u32; 6] = [64, 128, 256, 512, 1024, 2048];

/// Texture arrays bound: one per size class.
pub const TEXTURE_ARRAYS: u32 = TEXTURE_SIZES.len() as u32;

/// GPU memory the scene's textures may take by default, mip levels included.
pub const DEFAULT_TEXTURE_BUDGET: u64 = 1 << 30;

/// `GpuTextureRef::image` bits: the layer in the low 24 bits, the size class above them and
/// the encoding in bit 28.
/// Layer bytes (mip levels included) whose chains are made together, on every core: what bounds
/// the texels an upload holds at once.
const BATCH_BYTES: u64 = 128 << 20;

const CLASS_SHIFT: u32 = 24;
const SRGB_BIT: u32 = 1 << 28;

/// How much of the scene's textures goes to the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureOptions {
    /// Bytes all texture arrays may take; textures are downscaled (with a warning) to fit.
    pub budget_bytes: u64,
    /// Largest layer side, at most 2048 (and the adapter's limit).
    pub max_size: u32,
}

impl TextureOptions {
    /// [`DEFAULT_TEXTURE_BUDGET`] and the largest size class.
    pub const DEFAULT: Self = Self {
        budget_bytes: DEFAULT_TEXTURE_BUDGET,
        max_size: TEXTURE_SIZES[TEXTURE_SIZES.len() - 1],
    };
}

impl Default for TextureOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why a scene's textures cannot go to the GPU.
#[derive(Debug, Error, PartialEq)]
pub enum TextureError {
    /// More textures of one size class than an array may have layers.
    #[error(
        "{layers} textures of {size}x{size} texels need as many texture array layers, but the \
         adapter's `max_texture_array_layers` is {limit}; lower the texture budget so textures \
         fall into smaller classes, or use fewer textures"
    )]
    TooManyLayers { size: u32, layers: u32, limit: u32 },
    /// The adapter cannot bind the texture arrays in one shader stage.
    #[error(
        "the adapter's `max_sampled_textures_per_shader_stage` is {limit}, but the scene's \
         texture arrays need {needed}"
    )]
    TooFewSampledTextures { needed: u32, limit: u32 },
    /// The adapter's `max_texture_dimension_2d` is below the smallest size class.
    #[error(
        "the adapter's `max_texture_dimension_2d` is {limit}, below the {needed} texels the \
         smallest texture class needs"
    )]
    DimensionTooSmall { needed: u32, limit: u32 },
}

/// One texture reference as the shaders read it (`TextureRef` in WGSL), 48 bytes: the array
/// layer and the texture-coordinate transform, the tiling folded in.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTextureRef {
    /// Layer in bits 0..24, size class (index into [`TEXTURE_SIZES`]) in bits 24..28, 1 in
    /// bit 28 for an sRGB-encoded texture.
    pub image: u32,
    /// Texture coordinate set: 0 or 1.
    pub tex_coord: u32,
    /// Side of the layer in texels (for the level of detail).
    pub size: f32,
    pub pad: u32,
    /// Layer coordinate `u = dot(row_u.xyz, (u, v, 1))` of the vertex coordinate `(u, v)`.
    pub row_u: [f32; 4],
    /// `v = dot(row_v.xyz, (u, v, 1))`.
    pub row_v: [f32; 4],
}

/// The scene's texture arrays, their bind group and the reference table.
pub struct SceneTextures {
    arrays: Vec<wgpu::Texture>,
    /// Bind group [`TEXTURE_BIND_GROUP`] of every pass that samples textures.
    pub bind_group: wgpu::BindGroup,
    /// Reference table; materials hold indices into it.
    pub refs: Vec<GpuTextureRef>,
    ref_index: HashMap<RefKey, u32>,
    /// Per scene texture: its layer's `image` word, size and tiling, when it is used.
    placements: Vec<Option<Placement>>,
    /// Bytes of all arrays, mip levels included.
    pub bytes: u64,
    /// Downscaled textures, resampled ones.
    pub warnings: Vec<String>,
}

/// Where one scene texture lives: the `image` word and how many times it repeats across its
/// layer on each axis.
#[derive(Clone, Copy, Debug)]
struct Placement {
    image: u32,
    size: u32,
    tiles: [f32; 2],
}

/// A texture reference's identity for deduplication (the transform by its bits).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct RefKey {
    texture: usize,
    tex_coord: u32,
    transform: [u32; 5],
}

impl RefKey {
    fn of(r: &TextureRef) -> Self {
        let t = r.transform;
        Self {
            texture: r.texture,
            tex_coord: r.tex_coord,
            transform: [
                t.offset.x.to_bits(),
                t.offset.y.to_bits(),
                t.rotation.to_bits(),
                t.scale.x.to_bits(),
                t.scale.y.to_bits(),
            ],
        }
    }
}

/// A texture's plan: its power-of-two size before downscaling, and the mip levels dropped.
#[derive(Clone, Copy, Debug)]
struct Plan {
    texture: usize,
    /// Power-of-two width and height (the texture's own, or resampled to).
    pow2: [u32; 2],
    /// Top mip levels dropped to fit the budget and the largest size.
    dropped: u32,
}

impl Plan {
    /// Width and height of level 0 on the GPU.
    fn size(&self) -> [u32; 2] {
        self.pow2.map(|s| (s >> self.dropped).max(1))
    }

    /// Side of the layer: the larger of the two, at least the smallest class.
    fn layer_size(&self) -> u32 {
        let [w, h] = self.size();
        w.max(h).max(TEXTURE_SIZES[0])
    }
}

/// Bytes of one layer of side `size` with its full mip chain.
fn layer_bytes(size: u32) -> u64 {
    let mut bytes = 0;
    let mut s = u64::from(size);
    while s >= 1 {
        bytes += s * s * 4;
        s /= 2;
    }
    bytes
}

fn class_of(size: u32) -> usize {
    TEXTURE_SIZES
        .iter()
        .position(|&s| s == size)
        .expect("layer sizes are size classes")
}

/// Mip levels of a square layer of side `size`.
fn mip_levels(size: u32) -> u32 {
    size.ilog2() + 1
}

impl SceneTextures {
    /// The layout of bind group [`TEXTURE_BIND_GROUP`]: the sampler at binding 0, then the
    /// array of each size class (bindings 1..=6, smallest first).
    pub fn bind_group_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        }];
        entries.extend(
            (1..=TEXTURE_ARRAYS).map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            }),
        );
        ctx.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("scene.textures"),
                entries: &entries,
            })
    }

    /// Checks the adapter limits the texture arrays need, before anything is created.
    pub fn check_limits(limits: &wgpu::Limits) -> Result<(), TextureError> {
        if limits.max_sampled_textures_per_shader_stage < TEXTURE_ARRAYS {
            return Err(TextureError::TooFewSampledTextures {
                needed: TEXTURE_ARRAYS,
                limit: limits.max_sampled_textures_per_shader_stage,
            });
        }
        if limits.max_texture_dimension_2d < TEXTURE_SIZES[0] {
            return Err(TextureError::DimensionTooSmall {
                needed: TEXTURE_SIZES[0],
                limit: limits.max_texture_dimension_2d,
            });
        }
        Ok(())
    }

    /// Uploads every texture of `scene` that a material uses. Cost: mip chains built on the
    /// CPU (a third more texels than the images), one copy per level and layer.
    pub fn upload(
        ctx: &GpuContext,
        scene: &Scene,
        options: &TextureOptions,
    ) -> Result<Self, TextureError> {
        Self::check_limits(&ctx.limits)?;
        let mut warnings = Vec::new();
        let mut used = vec![false; scene.textures.len()];
        for r in scene.materials.iter().flat_map(|m| m.texture_refs()) {
            if let Some(slot) = used.get_mut(r.texture) {
                *slot = scene.textures[r.texture].is_valid();
            }
        }
        let max_size = options
            .max_size
            .min(ctx.limits.max_texture_dimension_2d)
            .clamp(
                TEXTURE_SIZES[0],
                *TEXTURE_SIZES.last().expect("size classes"),
            );
        let max_size = 1 << max_size.ilog2();
        let mut plans: Vec<Plan> = Vec::new();
        for (index, texture) in scene.textures.iter().enumerate() {
            if !used[index] {
                continue;
            }
            let pow2 = [texture.width, texture.height].map(u32::next_power_of_two);
            if pow2 != [texture.width, texture.height] {
                warnings.push(format!(
                    "texture {index} ('{}') is {}x{}: resampled to {}x{} on the GPU",
                    texture.name, texture.width, texture.height, pow2[0], pow2[1]
                ));
            }
            let mut plan = Plan {
                texture: index,
                pow2,
                dropped: 0,
            };
            while plan.size()[0].max(plan.size()[1]) > max_size {
                plan.dropped += 1;
            }
            plans.push(plan);
        }
        let total =
            |plans: &[Plan]| -> u64 { plans.iter().map(|p| layer_bytes(p.layer_size())).sum() };
        let before = total(&plans);
        let mut downscaled = 0;
        while total(&plans) > options.budget_bytes {
            let Some(largest) = plans
                .iter_mut()
                .filter(|p| p.layer_size() > TEXTURE_SIZES[0])
                .max_by_key(|p| p.layer_size())
            else {
                break;
            };
            largest.dropped += 1;
            downscaled += 1;
        }
        if downscaled > 0 {
            warnings.push(format!(
                "textures take {} MiB with their mip levels, over the texture budget of {} MiB: \
                 the largest were halved {downscaled} times to {} MiB",
                before >> 20,
                options.budget_bytes >> 20,
                total(&plans) >> 20
            ));
        }

        // Layers per size class.
        let mut layers = [0u32; TEXTURE_SIZES.len()];
        let mut placements = vec![None; scene.textures.len()];
        for plan in &plans {
            let size = plan.layer_size();
            let class = class_of(size);
            let srgb = scene.textures[plan.texture].encoding == TextureEncoding::Srgb;
            let layer = layers[class];
            layers[class] += 1;
            let [w, h] = plan.size();
            placements[plan.texture] = Some(Placement {
                image: layer | (class as u32) << CLASS_SHIFT | if srgb { SRGB_BIT } else { 0 },
                size,
                tiles: [(size / w) as f32, (size / h) as f32],
            });
        }
        for (class, &count) in layers.iter().enumerate() {
            if count > ctx.limits.max_texture_array_layers {
                return Err(TextureError::TooManyLayers {
                    size: TEXTURE_SIZES[class],
                    layers: count,
                    limit: ctx.limits.max_texture_array_layers,
                });
            }
        }

        // Arrays at bindings 1..=6; empty ones are a 1x1 placeholder layer, which no
        // reference names.
        let arrays: Vec<wgpu::Texture> = TEXTURE_SIZES
            .iter()
            .zip(layers)
            .map(|(&size, count)| {
                let (side, count, mips) = if count == 0 {
                    (1, 1, 1)
                } else {
                    (size, count, mip_levels(size))
                };
                ctx.create_texture(&wgpu::TextureDescriptor {
                    label: Some("scene.textures"),
                    size: wgpu::Extent3d {
                        width: side,
                        height: side,
                        depth_or_array_layers: count,
                    },
                    mip_level_count: mips,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba8Unorm,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                })
            })
            .collect();
        let array_of = |image: u32| &arrays[((image >> CLASS_SHIFT) & 0xf) as usize];
        // The mip chains are made on every core, a batch of textures at a time so that their
        // texels (and the linear values they are averaged in) never all sit in memory at once.
        let mut next = 0;
        while next < plans.len() {
            let mut end = next;
            let mut batch_bytes = 0;
            while end < plans.len()
                && (end == next
                    || batch_bytes + layer_bytes(plans[end].layer_size()) <= BATCH_BYTES)
            {
                batch_bytes += layer_bytes(plans[end].layer_size());
                end += 1;
            }
            let levels: Vec<Vec<Vec<[u8; 4]>>> = plans[next..end]
                .par_iter()
                .map(|plan| {
                    let placement = placements[plan.texture].expect("planned textures are placed");
                    layer_levels(&scene.textures[plan.texture], plan, placement.size)
                })
                .collect();
            for (plan, levels) in plans[next..end].iter().zip(levels) {
                let placement = placements[plan.texture].expect("planned textures are placed");
                for (level, texels) in (0u32..).zip(&levels) {
                    let side = placement.size >> level;
                    ctx.queue.write_texture(
                        wgpu::TexelCopyTextureInfo {
                            texture: array_of(placement.image),
                            mip_level: level,
                            origin: wgpu::Origin3d {
                                x: 0,
                                y: 0,
                                z: placement.image & ((1 << CLASS_SHIFT) - 1),
                            },
                            aspect: wgpu::TextureAspect::All,
                        },
                        bytemuck::cast_slice(texels),
                        wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(side * 4),
                            rows_per_image: Some(side),
                        },
                        wgpu::Extent3d {
                            width: side,
                            height: side,
                            depth_or_array_layers: 1,
                        },
                    );
                }
            }
            next = end;
        }
        let bytes = arrays
            .iter()
            .map(|a| {
                let side = a.width();
                let per_layer = if a.mip_level_count() == 1 {
                    u64::from(side) * u64::from(side) * 4
                } else {
                    layer_bytes(side)
                };
                per_layer * u64::from(a.depth_or_array_layers())
            })
            .sum();

        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("scene.textures"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            address_mode_w: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let views: Vec<wgpu::TextureView> = arrays
            .iter()
            .map(|a| {
                a.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("scene.textures"),
                    dimension: Some(wgpu::TextureViewDimension::D2Array),
                    ..Default::default()
                })
            })
            .collect();
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Sampler(&sampler),
        }];
        entries.extend(
            views
                .iter()
                .zip(1..)
                .map(|(view, binding)| wgpu::BindGroupEntry {
                    binding,
                    resource: wgpu::BindingResource::TextureView(view),
                }),
        );
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene.textures"),
            layout: &Self::bind_group_layout(ctx),
            entries: &entries,
        });
        Ok(Self {
            arrays,
            bind_group,
            refs: Vec::new(),
            ref_index: HashMap::new(),
            placements,
            bytes,
            warnings,
        })
    }

    /// The table index of texture reference `r`, adding it on first use; `None` (no texture,
    /// or one that was not uploaded) gives [`crate::NO_TEXTURE`].
    pub fn reference(&mut self, r: Option<TextureRef>) -> u32 {
        let Some(r) = r else {
            return crate::NO_TEXTURE;
        };
        let Some(placement) = self.placements.get(r.texture).copied().flatten() else {
            return crate::NO_TEXTURE;
        };
        let key = RefKey::of(&r);
        if let Some(&index) = self.ref_index.get(&key) {
            return index;
        }
        let m = r.transform.matrix();
        let [tiles_u, tiles_v] = placement.tiles;
        let row_u = [m.matrix2.x_axis.x, m.matrix2.y_axis.x, m.translation.x].map(|c| c / tiles_u);
        let row_v = [m.matrix2.x_axis.y, m.matrix2.y_axis.y, m.translation.y].map(|c| c / tiles_v);
        self.refs.push(GpuTextureRef {
            image: placement.image,
            tex_coord: r.tex_coord.min(1),
            size: placement.size as f32,
            pad: 0,
            row_u: [row_u[0], row_u[1], row_u[2], 0.0],
            row_v: [row_v[0], row_v[1], row_v[2], 0.0],
        });
        let index = self.refs.len() as u32 - 1;
        self.ref_index.insert(key, index);
        index
    }

    /// Stops counting and destroys the arrays.
    pub fn release(&self, ctx: &GpuContext) {
        for array in &self.arrays {
            ctx.release_texture(array);
        }
    }
}

/// The texels of every mip level of `texture`'s layer of side `size` under `plan`: its chain
/// from the plan's first kept level, each level tiled over the layer's level.
fn layer_levels(texture: &Texture, plan: &Plan, size: u32) -> Vec<Vec<[u8; 4]>> {
    let chain = mip_chain(texture, plan.pow2);
    (0..mip_levels(size))
        .map(|level| {
            let source = chain
                .get((plan.dropped + level) as usize)
                .unwrap_or_else(|| chain.last().expect("a chain has level 0"));
            tile(source, size >> level)
        })
        .collect()
}

/// The texture's mip chain at power-of-two size `pow2` (resampled first when its own size
/// differs), as stored 8-bit texels in its encoding; level 0 first, down to 1x1.
fn mip_chain(texture: &Texture, pow2: [u32; 2]) -> Vec<Level> {
    let [w, h] = pow2;
    let linear: Vec<Vec4> = if [texture.width, texture.height] == pow2 {
        texture.texels.iter().map(|&t| texture.decode(t)).collect()
    } else {
        (0..h)
            .flat_map(|y| {
                (0..w).map(move |x| {
                    texture.sample_bilinear(glam::Vec2::new(
                        (x as f32 + 0.5) / w as f32,
                        (y as f32 + 0.5) / h as f32,
                    ))
                })
            })
            .collect()
    };
    let encode = |values: &[Vec4]| -> Vec<[u8; 4]> {
        let level = Texture::from_linear("", 1, 1, texture.encoding, values);
        level.texels
    };
    let mut chain = vec![Level {
        width: w,
        height: h,
        texels: if [texture.width, texture.height] == pow2 {
            texture.texels.clone()
        } else {
            encode(&linear)
        },
    }];
    let (mut values, mut width, mut height) = (linear, w, h);
    while width > 1 || height > 1 {
        let (nw, nh) = ((width / 2).max(1), (height / 2).max(1));
        let (dx, dy) = (u32::from(width > 1), u32::from(height > 1));
        let mut next = Vec::with_capacity((nw * nh) as usize);
        for y in 0..nh {
            let sy = y * height / nh;
            let (row, below) = ((sy * width) as usize, ((sy + dy) * width) as usize);
            for x in 0..nw {
                let sx = x * width / nw;
                let (left, right) = (sx as usize, (sx + dx) as usize);
                next.push(
                    (values[row + left]
                        + values[row + right]
                        + values[below + left]
                        + values[below + right])
                        * 0.25,
                );
            }
        }
        chain.push(Level {
            width: nw,
            height: nh,
            texels: encode(&next),
        });
        (values, width, height) = (next, nw, nh);
    }
    chain
}

/// One mip level of a texture, stored texels.
struct Level {
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
}

/// `level` repeated to fill a `side` x `side` square (texel `(x, y)` is the level's
/// `(x mod width, y mod height)`).
fn tile(level: &Level, side: u32) -> Vec<[u8; 4]> {
    if level.width == side && level.height == side {
        return level.texels.clone();
    }
    let mut texels = Vec::with_capacity((side * side) as usize);
    for y in 0..side {
        let row = ((y % level.height) * level.width) as usize;
        for x in 0..side {
            texels.push(level.texels[row + (x % level.width) as usize]);
        }
    }
    texels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_bytes_count_every_mip_level() {
        assert_eq!(layer_bytes(1), 4);
        assert_eq!(layer_bytes(2), 4 * (4 + 1));
        assert_eq!(layer_bytes(64), 4 * (4096 + 1024 + 256 + 64 + 16 + 4 + 1));
    }

    #[test]
    fn mip_chains_average_linear_values_and_end_at_one_texel() {
        let texels = [Vec4::ONE, Vec4::ZERO, Vec4::ZERO, Vec4::ONE];
        for encoding in [TextureEncoding::Linear, TextureEncoding::Srgb] {
            let texture = Texture::from_linear("", 2, 2, encoding, &texels);
            let chain = mip_chain(&texture, [2, 2]);
            assert_eq!(chain.len(), 2);
            assert_eq!(chain[0].texels, texture.texels);
            // Half of the light in linear terms, whatever the encoding.
            let mean = texture.decode(chain[1].texels[0]);
            assert!((mean.x - 0.5).abs() < 0.01, "{encoding:?}: {mean}");
        }
        // A non-square one halves both sides until the short one stops at 1.
        let wide = Texture::from_linear("", 4, 1, TextureEncoding::Linear, &[Vec4::ONE; 4]);
        let sizes: Vec<_> = mip_chain(&wide, [4, 1])
            .iter()
            .map(|l| (l.width, l.height))
            .collect();
        assert_eq!(sizes, vec![(4, 1), (2, 1), (1, 1)]);
    }

    #[test]
    fn tiling_repeats_the_level() {
        let level = Level {
            width: 2,
            height: 1,
            texels: vec![[1; 4], [2; 4]],
        };
        let tiled = tile(&level, 4);
        assert_eq!(tiled.len(), 16);
        for y in 0..4 {
            assert_eq!(&tiled[y * 4..y * 4 + 4], &[[1; 4], [2; 4], [1; 4], [2; 4]]);
        }
    }
}
