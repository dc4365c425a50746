//! The examples run as a user runs them: the sequence of a scene built in code, the Auto
//! choice on a bundled scene, and the interactive viewer in a window (under Xvfb when no
//! display is set), whose screenshot is checked.

use std::path::Path;
use std::process::Command;

/// Set (as CI does) to fail the viewer's test instead of skipping it when there is neither a
/// display nor `xvfb-run`.
const REQUIRE_DISPLAY_ENV: &str = "GI_REQUIRE_DISPLAY";

fn run(command: &mut Command) -> String {
    let output = command.output().expect("the example starts");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "{command:?} failed: {}\n{stdout}\n{stderr}",
        output.status
    );
    stdout
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// Mean of red minus green over the pixels in `x0..x1` x `y0..y1`, in 8-bit units.
fn red_minus_green(image: &image::RgbImage, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> f64 {
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            let p = image.get_pixel(x, y);
            sum += f64::from(p[0]) - f64::from(p[1]);
        }
    }
    sum / f64::from((x1 - x0) * (y1 - y0))
}

/// The red wall shows in `left`'s columns and the green one in `right`'s, over `rows`: red
/// minus green is larger on the left than on the right by 20 levels of 255 at least (a
/// mirrored or swapped image gives the opposite sign).
fn check_walls(image: &image::RgbImage, rows: (u32, u32), left: (u32, u32), right: (u32, u32)) {
    let on_left = red_minus_green(image, left, rows);
    let on_right = red_minus_green(image, right, rows);
    println!("red minus green: {on_left:.1} on the left, {on_right:.1} on the right");
    assert!(
        on_left - on_right > 20.0,
        "red minus green: {on_left:.1} on the left, {on_right:.1} on the right"
    );
}

#[test]
fn the_sequence_renders_a_scene_built_in_code_with_a_moving_box() {
    let out = tempfile::tempdir().unwrap();
    let stdout = run(Command::new(env!("CARGO_BIN_EXE_sequence"))
        .args([
            "--tier", "path", "--frames", "2", "--width", "64", "--height", "36",
        ])
        .arg("--out")
        .arg(out.path())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir()));
    assert!(stdout.contains("tier: path"), "{stdout}");
    let first = rgb(&out.path().join("frame-000.png"));
    let second = rgb(&out.path().join("frame-001.png"));
    assert_eq!(first.dimensions(), (64, 36));
    assert_ne!(
        first.as_raw(),
        second.as_raw(),
        "the camera and the box moved"
    );
    // The red wall shows in the left half, the green one in the right, and not the other way.
    let rows = (0, 36);
    let (left, right) = ((0, 32), (32, 64));
    check_walls(&first, rows, left, right);
}

#[test]
fn auto_picks_a_tier_and_saves_the_last_frame() {
    let out = tempfile::tempdir().unwrap();
    let png = out.path().join("last.png");
    let stdout = run(Command::new(env!("CARGO_BIN_EXE_auto"))
        .args([
            "cornell-box",
            "--frames",
            "1",
            "--width",
            "32",
            "--height",
            "24",
        ])
        .arg("--out")
        .arg(&png)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir()));
    assert!(stdout.contains("tier: "), "{stdout}");
    assert_eq!(rgb(&png).dimensions(), (32, 24));
}

/// The viewer runs 3 frames of the Cornell box with the path tier in a 320 x 240 window and
/// saves what the window shows: the box (red wall left, green wall right, below the text) and
/// the overlay's light text on its dark box at the top left.
#[test]
fn the_viewer_shows_the_frame_and_its_timings_in_a_window() {
    let has_display = std::env::var_os("DISPLAY").is_some();
    let has_xvfb = Command::new("xvfb-run").arg("--help").output().is_ok();
    if !has_display && !has_xvfb {
        assert!(
            std::env::var_os(REQUIRE_DISPLAY_ENV).is_none(),
            "{REQUIRE_DISPLAY_ENV} is set but there is no display and no xvfb-run \
             (Debian: apt-get install xvfb xauth)"
        );
        eprintln!("SKIPPED: the viewer's test needs a display or xvfb-run");
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let shot = out.path().join("shot.png");
    let viewer = env!("CARGO_BIN_EXE_viewer");
    let mut command = if has_display {
        Command::new(viewer)
    } else {
        let mut xvfb = Command::new("xvfb-run");
        xvfb.args(["-a", "-s", "-screen 0 640x480x24", viewer]);
        xvfb
    };
    let stdout = run(command
        .args([
            "cornell-box",
            "--tier",
            "path",
            "--size",
            "320x240",
            "--spp",
            "8",
        ])
        .args(["--frames", "3", "--screenshot"])
        .arg(&shot)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir()));
    assert!(stdout.contains("path/trace"), "no pass timings: {stdout}");
    let image = rgb(&shot);
    assert_eq!(image.dimensions(), (320, 240));
    // Below the overlay: the red wall on the left, the green one on the right.
    let rows = (160, 240);
    check_walls(&image, rows, (0, 160), (160, 320));
    // The overlay: light glyphs and their dark box in the first text line.
    let line: Vec<_> = (0..200)
        .flat_map(|x| (4..18).map(move |y| (x, y)))
        .map(|(x, y)| *image.get_pixel(x, y))
        .collect();
    let light = line.iter().filter(|p| p[0] > 200 && p[1] > 200).count();
    let dark = line.iter().filter(|p| p[0] < 80 && p[1] < 80).count();
    assert!(
        light > 100 && dark > 100,
        "overlay: {light} light, {dark} dark"
    );
}
