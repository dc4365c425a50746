//! FLIP (LDR): known answers from NVIDIA's reference, and the properties a metric must have.

use gi_image::{
    FLIP_PIXELS_PER_DEGREE, Flip, Image, ImageError, flip_error_map, flip_ldr, read_png,
    rmse_srgb8, tonemap::srgb8_to_linear, write_flip_map,
};
use glam::Vec3;

const WIDTH: u32 = 96;
const HEIGHT: u32 = 64;

/// The reference's 8-bit code at `(x, y)`, channel `c`, with the bright square's left edge at
/// `square_x`: a red/green gradient over a blue checkerboard. `benchmarks/flip/check.py`
/// builds the same codes.
fn base(x: u32, y: u32, c: u32, square_x: u32) -> u32 {
    if (square_x..square_x + 16).contains(&x) && (20..36).contains(&y) {
        return 240;
    }
    match c {
        0 => x * 255 / (WIDTH - 1),
        1 => y * 255 / (HEIGHT - 1),
        _ if (x / 8 + y / 8).is_multiple_of(2) => 200,
        _ => 40,
    }
}

/// Hashed noise in `-16..=15` codes.
fn noise(x: u32, y: u32, c: u32) -> i32 {
    let h = x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663) ^ c.wrapping_mul(83_492_791);
    (h.wrapping_mul(2_654_435_761) >> 27) as i32 - 16
}

/// The known-answer pair as linear images whose 8-bit encoding at exposure 1 is exactly the
/// codes: the reference, and the test with its square moved 3 pixels right and noise added.
fn known_pair() -> (Image, Image) {
    let image = |code: &dyn Fn(u32, u32, u32) -> i32| {
        Image::from_fn(WIDTH, HEIGHT, |x, y| {
            Vec3::from_array([0, 1, 2].map(|c| srgb8_to_linear(code(x, y, c).clamp(0, 255) as u8)))
        })
    };
    let reference = image(&|x, y, c| base(x, y, c, 20) as i32);
    let test = image(&|x, y, c| base(x, y, c, 23) as i32 + noise(x, y, c));
    (reference, test)
}

/// NVIDIA's `flip-evaluator` 1.7 (the Python package of their reference implementation) on
/// the pair of [`known_pair`], LDR at its default viewing condition (67.02 pixels per degree),
/// printed by `benchmarks/flip/check.py`:
///
/// ```text
/// python3 -m venv /tmp/flipvenv && /tmp/flipvenv/bin/pip install flip-evaluator
/// /tmp/flipvenv/bin/python benchmarks/flip/check.py
/// ```
const REFERENCE_MEAN: f64 = 0.116_718_1;
const REFERENCE_MAX: f32 = 0.967_329_5;
/// `(x, y, error)` at a few pixels: a flat corner, inside the square's old and new edges, and
/// a textured region.
const REFERENCE_PROBES: [(u32, u32, f32); 4] = [
    (0, 0, 0.137_592_7),
    (21, 28, 0.948_331_3),
    (37, 30, 0.864_454_7),
    (60, 10, 0.046_316_7),
];

#[test]
fn agrees_with_nvidias_reference_on_a_known_pair() {
    let (reference, test) = known_pair();
    let flip = flip_ldr(&test, &reference, 1.0).unwrap();
    assert_eq!((flip.width, flip.height), (WIDTH, HEIGHT));
    assert_eq!(flip.errors.len(), (WIDTH * HEIGHT) as usize);
    assert!(
        (flip.mean - REFERENCE_MEAN).abs() < TOLERANCE,
        "mean {} against NVIDIA's {REFERENCE_MEAN}",
        flip.mean
    );
    let max = flip.errors.iter().copied().fold(0.0, f32::max);
    assert!((max - REFERENCE_MAX).abs() < TOLERANCE as f32, "max {max}");
    for (x, y, expected) in REFERENCE_PROBES {
        let error = flip.errors[(y * WIDTH + x) as usize];
        assert!(
            (error - expected).abs() < TOLERANCE as f32,
            "({x}, {y}): {error} against NVIDIA's {expected}"
        );
    }
}

/// Measured: the mean within 1e-7 of [`REFERENCE_MEAN`] (its printed digits), the max and the
/// probes within 6e-8, since both run NVIDIA's code on the same 8-bit pixels.
const TOLERANCE: f64 = 1e-6;

#[test]
fn uses_nvidias_default_viewing_condition() {
    // A 3840-pixel-wide display 0.7 m wide seen from 0.7 m.
    let ppd = 0.7 * 3840.0 / 0.7 * std::f64::consts::PI / 180.0;
    assert!((f64::from(FLIP_PIXELS_PER_DEGREE) - ppd).abs() < 1e-4);
}

#[test]
fn identical_images_have_zero_flip() {
    let (reference, _) = known_pair();
    let flip = flip_ldr(&reference, &reference, 1.0).unwrap();
    assert_eq!(flip.mean, 0.0);
    assert!(flip.errors.iter().all(|&e| e == 0.0));
    // Differences the 8-bit encoding removes are no difference: both clip to white.
    let bright = Image::from_fn(8, 8, |_, _| Vec3::splat(2.0));
    let brighter = Image::from_fn(8, 8, |_, _| Vec3::splat(3.0));
    assert_eq!(flip_ldr(&bright, &brighter, 1.0).unwrap().mean, 0.0);
}

#[test]
fn flip_is_bounded_symmetric_and_grows_with_the_difference() {
    let (reference, test) = known_pair();
    let forward = flip_ldr(&test, &reference, 1.0).unwrap();
    let backward = flip_ldr(&reference, &test, 1.0).unwrap();
    assert!(
        forward.errors.iter().all(|e| (0.0..=1.0).contains(e)),
        "errors out of 0..=1"
    );
    assert!(
        (forward.mean - backward.mean).abs() < 1e-4,
        "{} vs {}",
        forward.mean,
        backward.mean
    );
    // Black against white is the largest difference there is; mid grey lies between.
    let black = Image::new(16, 16);
    let white = Image::from_fn(16, 16, |_, _| Vec3::ONE);
    let grey = Image::from_fn(16, 16, |_, _| Vec3::splat(0.2));
    let full = flip_ldr(&white, &black, 1.0).unwrap().mean;
    let part = flip_ldr(&grey, &black, 1.0).unwrap().mean;
    assert!(0.0 < part && part < full && full <= 1.0, "{part} {full}");
}

#[test]
fn flip_measures_the_8_bit_encoding_that_rmse_srgb8_measures() {
    let (reference, test) = known_pair();
    let at_one = flip_ldr(&test, &reference, 1.0).unwrap();
    // Exposure scales before encoding: twice the light at half the exposure is the same PNG.
    let (mut reference2, mut test2) = (reference.clone(), test.clone());
    reference2.scale(2.0);
    test2.scale(2.0);
    assert_eq!(
        rmse_srgb8(&test2, &reference2, 0.5).unwrap(),
        rmse_srgb8(&test, &reference, 1.0).unwrap()
    );
    assert_eq!(flip_ldr(&test2, &reference2, 0.5).unwrap(), at_one);
    // Non-finite pixels are mapped as the tonemap maps them (NaN to black), never an error.
    let mut nan = test.clone();
    nan.set(3, 3, Vec3::splat(f32::NAN));
    let mut black = test.clone();
    black.set(3, 3, Vec3::ZERO);
    assert_eq!(
        flip_ldr(&nan, &reference, 1.0).unwrap(),
        flip_ldr(&black, &reference, 1.0).unwrap()
    );
}

#[test]
fn size_mismatch_and_empty_images_are_errors() {
    let err = flip_ldr(&Image::new(4, 2), &Image::new(2, 4), 1.0).unwrap_err();
    assert!(matches!(
        err,
        ImageError::SizeMismatch {
            a: (4, 2),
            b: (2, 4)
        }
    ));
    let empty = Image::new(0, 3);
    assert!(matches!(
        flip_ldr(&empty, &empty, 1.0).unwrap_err(),
        ImageError::Empty { .. }
    ));
    let hand_made = Flip {
        mean: 0.0,
        width: 3,
        height: 2,
        errors: vec![0.0; 5],
    };
    assert!(matches!(
        flip_error_map(&hand_made).unwrap_err(),
        ImageError::PixelCount { len: 5, .. }
    ));
}

#[test]
fn the_error_map_is_magma_and_written_as_is() {
    let (reference, test) = known_pair();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flip.png");
    let flip = write_flip_map(&test, &reference, 1.0, &path).unwrap();
    let map = flip_error_map(&flip).unwrap();
    assert_eq!(map.size(), (WIDTH, HEIGHT));
    // Magma runs from near-black (no error) to pale yellow (1): brightness grows with error.
    let at = |x: u32, y: u32| map.get(x, y);
    let (flat, edge) = (at(60, 10), at(21, 28));
    assert!(edge.element_sum() > flat.element_sum(), "{flat} {edge}");
    let zero = flip_error_map(&Flip {
        mean: 0.0,
        width: 1,
        height: 1,
        errors: vec![0.0],
    })
    .unwrap();
    assert!(zero.get(0, 0).element_sum() < 0.1, "{}", zero.get(0, 0));
    // The PNG holds the map's bytes, not a tonemapped version of them.
    let bytes = image::open(&path).unwrap().to_rgb8().into_raw();
    let expected: Vec<u8> = map
        .pixels
        .iter()
        .flat_map(|p| p.to_array().map(|v| (v * 255.0).round() as u8))
        .collect();
    assert_eq!(bytes, expected);
    // read_png decodes sRGB, so only the size is compared through it.
    assert_eq!(read_png(&path).unwrap().size(), (WIDTH, HEIGHT));
}
