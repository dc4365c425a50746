//! File round trips and file error reporting.

use std::path::Path;

use gi_image::{
    FileFormat, Image, ImageError, error_heatmap, heatmap_ramp, load, read_exr, read_png, save,
    srgb_eotf, to_srgb8, write_error_heatmap, write_exr, write_heatmap_png, write_png,
};
use glam::Vec3;

/// A gradient with values outside `0..=1`, so clamping and exposure matter.
fn gradient(width: u32, height: u32) -> Image {
    Image::from_fn(width, height, |x, y| {
        let u = x as f32 / (width - 1) as f32;
        let v = y as f32 / (height - 1) as f32;
        Vec3::new(u * 1.5, v, (u - v).abs() * 0.3 - 0.05)
    })
}

fn png_bytes(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

#[test]
fn exr_round_trip_is_bit_identical() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("reference.exr");
    let mut original = gradient(37, 19);
    // Values an HDR renderer produces that lossy or half-float storage would
    // alter: tiny, huge, negative zero, subnormal, and non-finite samples.
    original.set(0, 0, Vec3::new(1e-30, 3.4e38, -0.0));
    original.set(
        1,
        0,
        Vec3::new(f32::MIN_POSITIVE / 8.0, 1.000_000_1, 65_504.5),
    );
    original.set(2, 0, Vec3::new(f32::INFINITY, f32::NEG_INFINITY, f32::NAN));
    write_exr(&original, &path).unwrap();
    let read = read_exr(&path).unwrap();
    assert_eq!(read.size(), original.size());
    for (a, b) in read.pixels.iter().zip(&original.pixels) {
        assert_eq!(
            a.to_array().map(f32::to_bits),
            b.to_array().map(f32::to_bits)
        );
    }
}

#[test]
fn png_round_trip_within_8bit_quantisation() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.png");
    let original = gradient(64, 32);
    let exposure = 0.8;
    write_png(&original, &path, exposure).unwrap();
    let read = read_png(&path).unwrap();
    assert_eq!(read.size(), original.size());

    // The stored bytes are exactly the tonemap's output...
    assert_eq!(png_bytes(&path), to_srgb8(&original, exposure));
    // ...and decoding them re-encodes to the same bytes.
    assert_eq!(to_srgb8(&read, 1.0), to_srgb8(&original, exposure));

    // Half an 8-bit step of the sRGB curve is at most 0.0045 in linear light
    // (the curve is steepest at white).
    for (r, o) in read.pixels.iter().zip(&original.pixels) {
        let expected = (*o * exposure).clamp(Vec3::ZERO, Vec3::ONE);
        assert!(
            (*r - expected).abs().max_element() <= 0.0045,
            "{r} vs {expected}"
        );
    }
}

#[test]
fn png_stores_exposure_and_clamps() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("exposed.png");
    let image = Image::from_fn(3, 1, |x, _| Vec3::splat([0.25, 2.0, -1.0][x as usize]));
    write_png(&image, &path, 2.0).unwrap();
    // 0.25 * 2 = 0.5 encodes to 188; 4.0 clamps to 255; negatives clamp to 0.
    assert_eq!(
        png_bytes(&path),
        vec![188, 188, 188, 255, 255, 255, 0, 0, 0]
    );
    let read = read_png(&path).unwrap();
    assert_eq!(read.get(0, 0), Vec3::splat(srgb_eotf(188.0 / 255.0)));
    assert_eq!(read.get(1, 0), Vec3::ONE);
}

#[test]
fn reads_16_bit_pngs_at_full_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("deep.png");
    let buffer =
        image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(1, 1, vec![0u16, 32_768, 65_535])
            .unwrap();
    buffer.save(&path).unwrap();
    let read = read_png(&path).unwrap();
    let expected = Vec3::new(0.0, srgb_eotf(32_768.0 / 65_535.0), 1.0);
    assert!((read.get(0, 0) - expected).abs().max_element() < 1e-6);
}

#[test]
fn save_and_load_dispatch_on_extension_case_insensitively() {
    let dir = tempfile::tempdir().unwrap();
    let original = gradient(8, 4);

    let exr = dir.path().join("hdr.EXR");
    save(&original, &exr, 123.0).unwrap();
    assert_eq!(load(&exr).unwrap(), original, "EXR ignores exposure");

    let png = dir.path().join("ldr.Png");
    save(&original, &png, 0.5).unwrap();
    assert_eq!(png_bytes(&png), to_srgb8(&original, 0.5));
    assert_eq!(
        to_srgb8(&load(&png).unwrap(), 1.0),
        to_srgb8(&original, 0.5)
    );

    assert_eq!(
        FileFormat::from_path(Path::new("a/b.exr")).unwrap(),
        FileFormat::Exr
    );
}

#[test]
fn unsupported_extensions_are_rejected_with_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let image = gradient(2, 2);
    for name in ["frame.jpg", "frame", "frame.png.bak", "exr"] {
        let path = dir.path().join(name);
        let err = save(&image, &path, 1.0).unwrap_err();
        match &err {
            ImageError::UnsupportedFormat { path: p } => assert_eq!(p, &path),
            other => panic!("expected UnsupportedFormat, got {other:?}"),
        }
        assert!(err.to_string().contains(name));
        assert!(!path.exists(), "nothing is written for {name}");
        assert!(matches!(
            load(&path).unwrap_err(),
            ImageError::UnsupportedFormat { .. }
        ));
    }
}

#[test]
fn missing_files_report_io_errors_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["missing.exr", "missing.png"] {
        let path = dir.path().join(name);
        let err = load(&path).unwrap_err();
        match &err {
            ImageError::Io { path: p, source } => {
                assert_eq!(p, &path);
                assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
            }
            other => panic!("expected Io, got {other:?}"),
        }
        assert!(err.to_string().contains(&path.display().to_string()));
    }
    // Writing into a directory that does not exist is an I/O error too.
    let nowhere = dir.path().join("no-such-dir").join("out.exr");
    assert!(matches!(
        write_exr(&gradient(2, 2), &nowhere).unwrap_err(),
        ImageError::Io { path, .. } if path == nowhere
    ));
}

#[test]
fn corrupt_files_report_decode_errors_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["garbage.exr", "garbage.png"] {
        let path = dir.path().join(name);
        std::fs::write(&path, b"this is not an image file at all").unwrap();
        match load(&path).unwrap_err() {
            ImageError::Decode { path: p, message } => {
                assert_eq!(p, path);
                assert!(!message.is_empty());
            }
            other => panic!("expected Decode for {name}, got {other:?}"),
        }
    }
}

#[test]
fn empty_and_inconsistent_images_are_not_written() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["empty.png", "empty.exr"] {
        let path = dir.path().join(name);
        let err = save(&Image::new(0, 4), &path, 1.0).unwrap_err();
        assert!(
            matches!(&err, ImageError::Empty { path: Some(p), width: 0, height: 4 } if *p == path)
        );
        assert!(!path.exists());
    }
    let broken = Image {
        width: 3,
        height: 3,
        pixels: vec![Vec3::ZERO; 4],
    };
    let path = dir.path().join("broken.exr");
    assert!(matches!(
        write_exr(&broken, &path).unwrap_err(),
        ImageError::PixelCount { len: 4, .. }
    ));
}

#[test]
fn heatmap_png_stores_ramp_colours_directly() {
    let dir = tempfile::tempdir().unwrap();
    let reference = Image::new(2, 1);
    let image = Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32));

    let map = error_heatmap(&image, &reference, 1.0).unwrap();
    let path = dir.path().join("heat.png");
    write_heatmap_png(&map, &path).unwrap();
    // Zero error is the ramp's first control point, saturated error its last,
    // with no sRGB encoding applied on the way to the file.
    assert_eq!(png_bytes(&path), vec![0, 0, 4, 252, 255, 164]);

    let direct = dir.path().join("heat-direct.png");
    let info = write_error_heatmap(&image, &reference, 1.0, &direct).unwrap();
    assert_eq!(png_bytes(&direct), png_bytes(&path));
    assert_eq!(info.full_scale, gi_image::HEATMAP_FULL_SCALE);
    assert_eq!(info.max_error, 255.0);
}

#[test]
fn heatmap_of_identical_images_is_uniform_on_disk() {
    let dir = tempfile::tempdir().unwrap();
    let image = gradient(5, 4);
    let path = dir.path().join("same.png");
    let info = write_error_heatmap(&image, &image, 1.0, &path).unwrap();
    assert_eq!(info.max_error, 0.0);
    let zero = heatmap_ramp(0.0)
        .to_array()
        .map(|c| (c * 255.0).round() as u8);
    let bytes = png_bytes(&path);
    assert_eq!(bytes.len(), 5 * 4 * 3);
    assert!(bytes.chunks_exact(3).all(|px| px == zero));
}
