//! The Rust mirrors of the path tracer's GPU structs against naga's layout of the WGSL ones.

#[test]
fn shared_structs_match_their_wgsl_layout() {
    use gi_gpu::{
        GpuEmitter, GpuLight, GpuMaterial, GpuTextureRef, GpuTriangleExtras, GpuTriangleShading,
        ShaderLibrary, rust_field_offsets, wgsl_struct_layout,
    };
    use gi_tiers::PathUniforms;

    let module = ShaderLibrary::new()
        .compose("path/trace.wgsl", &[])
        .unwrap();
    // Padding is named differently on each side (`pad: [u32; 2]` against `pad_a`, `pad_b`):
    // the struct sizes cover it.
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let wgsl = wgsl_struct_layout(&module, name).unwrap_or_else(|| panic!("{name}"));
        let members: Vec<_> = wgsl
            .members
            .into_iter()
            .filter(|(member, _)| !member.starts_with("pad"))
            .collect();
        assert_eq!(members, rust, "{name}");
        assert_eq!(wgsl.size as usize, size, "{name}");
    };
    check(
        "PathUniforms",
        rust_field_offsets!(PathUniforms {
            camera,
            sky_zenith,
            sky_horizon,
            sky_ground,
            size_px,
            sample_offset,
            spp,
            seed,
            emitter_count,
            light_count,
            sky_emits,
            default_material,
            sky_kind,
            max_depth,
            first_row,
            loop_check,
        }),
        size_of::<PathUniforms>(),
    );
    check(
        "TriangleShading",
        rust_field_offsets!(GpuTriangleShading {
            pa,
            pb,
            pc,
            na,
            nb,
            nc,
            v,
            material
        }),
        size_of::<GpuTriangleShading>(),
    );
    check(
        "Material",
        rust_field_offsets!(GpuMaterial {
            base_color,
            emissive,
            metallic,
            roughness,
            base_color_texture,
            metallic_roughness_texture,
            emissive_texture,
            double_sided,
            specular,
            ior,
            specular_texture,
            specular_color,
            specular_color_texture,
            normal_texture,
            normal_scale,
            alpha_mode,
            alpha_cutoff,
            occlusion_texture,
            occlusion_strength,
        }),
        size_of::<GpuMaterial>(),
    );
    check(
        "TextureRef",
        rust_field_offsets!(GpuTextureRef {
            image,
            tex_coord,
            size,
            row_u,
            row_v
        }),
        size_of::<GpuTextureRef>(),
    );
    check(
        "TriangleExtras",
        rust_field_offsets!(GpuTriangleExtras {
            ta,
            tb,
            tc,
            uv_ab,
            uv_c
        }),
        size_of::<GpuTriangleExtras>(),
    );
    check(
        "Emitter",
        rust_field_offsets!(GpuEmitter {
            triangle,
            threshold
        }),
        size_of::<GpuEmitter>(),
    );
    check(
        "PunctualLight",
        rust_field_offsets!(GpuLight {
            position,
            kind,
            direction,
            range,
            intensity,
            has_range,
            cos_outer,
            spot_scale,
        }),
        size_of::<GpuLight>(),
    );
}
