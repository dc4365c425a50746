//! The suite's PNG figures: error against time, per-pass cost per tier, and a contact sheet
//! per scene. Plots are drawn with plotters into an RGB buffer and encoded by `image`; text
//! uses the bundled DejaVu Sans (`benchmarks/assets/`), so no system font is needed.

use std::{path::Path, sync::Once};

use anyhow::{Result, anyhow};
use image::{RgbImage, imageops::FilterType};
use plotters::{
    coord::{
        Shift,
        ranged1d::{AsRangedCoord, ValueFormatter},
    },
    prelude::*,
    style::text_anchor::{HPos, Pos, VPos},
};

use super::{
    file_stem,
    results::{Cell, Results},
};

/// Width of each image on a contact sheet, in pixels.
pub const THUMBNAIL_WIDTH: u32 = 320;

const FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Registers the bundled font as plotters' `sans-serif` (once per process).
pub fn register_font() -> Result<()> {
    static REGISTER: Once = Once::new();
    let mut result = Ok(());
    REGISTER.call_once(|| {
        result = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| anyhow!("the bundled font does not parse"));
    });
    result
}

fn plot_error(error: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("drawing a plot: {error}")
}

/// Draws into a white `size` canvas with `draw` and writes it to `path` as PNG.
fn draw_png(path: &Path, size: (u32, u32), draw: impl FnOnce(&Area) -> Result<()>) -> Result<()> {
    let mut buffer = vec![255u8; (size.0 * size.1 * 3) as usize];
    write_png(path, size, &mut buffer, draw)
}

/// Draws over the RGB `buffer` of `size` with `draw` and writes it to `path` as PNG.
fn write_png(
    path: &Path,
    size: (u32, u32),
    buffer: &mut Vec<u8>,
    draw: impl FnOnce(&Area) -> Result<()>,
) -> Result<()> {
    {
        let root = BitMapBackend::with_buffer(buffer, size).into_drawing_area();
        draw(&root)?;
        root.present().map_err(plot_error)?;
    }
    let image = RgbImage::from_raw(size.0, size.1, std::mem::take(buffer))
        .expect("the buffer holds the canvas");
    image
        .save(path)
        .map_err(|e| anyhow!("writing {}: {e}", path.display()))
}

/// Colour of the `index`th tier or pass.
fn colour(index: usize) -> RGBColor {
    const COLOURS: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    let base = COLOURS[index % COLOURS.len()];
    // Past ten, darken, so long pass lists stay distinguishable.
    let shade = 1.0 - 0.35 * ((index / COLOURS.len()) % 3) as f64;
    let scale = |c: u8| (f64::from(c) * shade) as u8;
    RGBColor(scale(base.0), scale(base.1), scale(base.2))
}

/// Marker of the `index`th tier: a distinct shape and colour at `at`.
fn marker<DB: DrawingBackend>(index: usize, at: (i32, i32)) -> DynElement<'static, DB, (i32, i32)> {
    let style = colour(index).filled();
    let (x, y) = at;
    match index % 4 {
        0 => Circle::new(at, 5, style).into_dyn(),
        1 => TriangleMarker::new(at, 7, style).into_dyn(),
        2 => Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], style).into_dyn(),
        _ => Cross::new(at, 5, colour(index).stroke_width(3)).into_dyn(),
    }
}

/// `error_vs_time.png`: rmse_srgb8 against ms per frame, a point per scene, a marker per tier.
/// The time axis is logarithmic when the slowest point is over 20 times the fastest.
pub fn error_vs_time(results: &Results, path: &Path) -> Result<()> {
    let tiers = &results.options.tiers;
    let points: Vec<(usize, &str, f64, f64, bool)> = results
        .cells
        .iter()
        .filter_map(|cell| {
            let tier = tiers.iter().position(|t| *t == cell.tier)?;
            Some((
                tier,
                cell.scene.as_str(),
                cell.ms_per_frame.as_ref()?.mean.max(1e-3),
                cell.rmse_srgb8.as_ref()?.mean,
                cell.on_cpu == Some(true),
            ))
        })
        .collect();
    let (min_ms, max_ms) = points
        .iter()
        .fold((f64::MAX, 0f64), |(lo, hi), p| (lo.min(p.2), hi.max(p.2)));
    let max_rmse = points.iter().map(|p| p.3).fold(0.0, f64::max).max(1e-3) * 1.15;
    let wide = points.is_empty() || max_ms > 20.0 * min_ms;
    let (lo, hi) = if points.is_empty() {
        (0.1, 10.0)
    } else {
        (min_ms, max_ms)
    };
    let legend_width = 200;
    draw_png(path, (1100 + legend_width, 720), |root| {
        root.fill(&WHITE).map_err(plot_error)?;
        let (plot, legend) = root.split_horizontally(1100);
        if wide {
            error_chart(&plot, (lo / 1.5..hi * 1.5).log_scale(), max_rmse, &points)?;
        } else {
            let pad = (hi - lo).max(hi * 0.1) * 0.15;
            error_chart(&plot, (lo - pad).max(0.0)..hi + pad, max_rmse, &points)?;
        }
        // The legend beside the plot, where it cannot hide a point.
        for (index, tier) in tiers.iter().enumerate() {
            let on_cpu = points.iter().any(|p| p.0 == index && p.4);
            let label = if on_cpu {
                format!("{tier} (CPU)")
            } else {
                tier.clone()
            };
            let y = 60 + 26 * index as i32;
            legend
                .draw(&marker(index, (14, y + 8)))
                .map_err(plot_error)?;
            legend
                .draw(&Text::new(label, (30, y), ("sans-serif", 15).into_font()))
                .map_err(plot_error)?;
        }
        Ok(())
    })
}

fn error_chart<X>(
    root: &Area,
    x: X,
    max_rmse: f64,
    points: &[(usize, &str, f64, f64, bool)],
) -> Result<()>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption("rmse_srgb8 against time per frame", ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(60)
        .build_cartesian_2d(x, 0.0..max_rmse)
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_labels(8)
        .x_label_formatter(&|ms| {
            if *ms >= 10.0 {
                format!("{ms:.0}")
            } else {
                format!("{ms:.2}")
            }
        })
        .x_desc("ms per frame (median of the measured frames; CPU tiers marked)")
        .y_desc("rmse_srgb8 (0..255, lower is better)")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(plot_error)?;
    let tiers = points.iter().map(|p| p.0).max().map_or(0, |max| max + 1);
    for index in 0..tiers {
        chart
            .draw_series(points.iter().filter(|p| p.0 == index).map(|p| {
                EmptyElement::at((p.2, p.3))
                    + marker(index, (0, 0))
                    + Text::new(p.1.to_owned(), (7, -16), ("sans-serif", 13).into_font())
            }))
            .map_err(plot_error)?;
    }
    Ok(())
}

/// `passes_<tier>.png`: a bar per scene stacking the tier's passes' median ms, with a legend.
/// `false` when no scene measured the tier.
pub fn passes(results: &Results, tier: &str, path: &Path) -> Result<bool> {
    let Some((cells, names)) = results.pass_cells(tier) else {
        return Ok(false);
    };
    let max_ms = cells
        .iter()
        .map(|c| c.passes_ms.iter().map(|p| p.ms.mean).sum::<f64>())
        .fold(0.0, f64::max)
        .max(1e-3)
        * 1.1;
    let legend_width = 300;
    let width = (160 * cells.len() as u32 + 200).max(640) + legend_width;
    let height = (22 * names.len() as u32 + 120).max(560);
    draw_png(path, (width, height), |root| {
        root.fill(&WHITE).map_err(plot_error)?;
        let (plot, legend) = root.split_horizontally(width - legend_width);
        let mut chart = ChartBuilder::on(&plot)
            .caption(
                format!("{tier}: median ms per pass and frame"),
                ("sans-serif", 22),
            )
            .margin(16)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..cells.len() as f64, 0.0..max_ms)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc("ms")
            .label_style(("sans-serif", 14))
            // Scene names go under the bars below, where the axis's own labels cannot be put.
            .x_label_formatter(&|_| String::new())
            .draw()
            .map_err(plot_error)?;
        for (index, name) in names.iter().enumerate() {
            let bars = cells.iter().enumerate().filter_map(|(scene, cell)| {
                let ms = cell.passes_ms.iter().find(|p| p.name == *name)?.ms.mean;
                let start: f64 = cell
                    .passes_ms
                    .iter()
                    .take_while(|p| p.name != *name)
                    .map(|p| p.ms.mean)
                    .sum();
                let x = scene as f64;
                Some(Rectangle::new(
                    [(x + 0.2, start), (x + 0.8, start + ms)],
                    colour(index).filled(),
                ))
            });
            chart.draw_series(bars).map_err(plot_error)?;
        }
        let centred = ("sans-serif", 14)
            .into_font()
            .into_text_style(root)
            .pos(Pos::new(HPos::Center, VPos::Top));
        for (scene, cell) in cells.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(scene as f64 + 0.5, 0.0));
            root.draw(&Text::new(cell.scene.clone(), (x, y + 8), centred.clone()))
                .map_err(plot_error)?;
        }
        // The legend, top to bottom in stacking order (bottom of the bar first).
        for (index, name) in names.iter().enumerate() {
            let y = 50 + 22 * index as i32;
            legend
                .draw(&Rectangle::new(
                    [(10, y), (24, y + 14)],
                    colour(index).filled(),
                ))
                .map_err(plot_error)?;
            legend
                .draw(&Text::new(
                    name.to_string(),
                    (32, y),
                    ("sans-serif", 14).into_font(),
                ))
                .map_err(plot_error)?;
        }
        Ok(())
    })?;
    Ok(true)
}

/// `contact_<scene>.png`: for each tier a row `tier image | reference | error heat map | FLIP
/// map`, scaled to [`THUMBNAIL_WIDTH`], labelled; from the PNGs in `images`. `false` when the
/// scene has no reference image.
pub fn contact_sheet(results: &Results, scene: &str, images: &Path, path: &Path) -> Result<bool> {
    let stem = file_stem(scene);
    let Some(reference) = thumbnail(&images.join(format!("{stem}_reference.png")))? else {
        return Ok(false);
    };
    let rows: Vec<(&Cell, RgbImage, RgbImage, RgbImage)> = results
        .cells
        .iter()
        .filter(|c| c.scene == scene)
        .filter_map(|cell| {
            let image = |suffix: &str| {
                thumbnail(&images.join(format!("{stem}_{}{suffix}.png", cell.tier))).ok()?
            };
            Some((cell, image("")?, image("_error")?, image("_flip")?))
        })
        .collect();
    let (margin, label) = (10u32, 24u32);
    let (tw, th) = reference.dimensions();
    let width = 4 * tw + 5 * margin;
    let row_height = label + th + margin;
    let height = 40 + row_height * rows.len().max(1) as u32;
    let mut canvas = RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
    for (row, (_, image, error, flip)) in rows.iter().enumerate() {
        let y = 40 + row as u32 * row_height + label;
        for (column, picture) in [image, &reference, error, flip].into_iter().enumerate() {
            let x = margin + column as u32 * (tw + margin);
            image::imageops::replace(&mut canvas, picture, i64::from(x), i64::from(y));
        }
    }
    let reference_spp = results.options.reference_spp;
    let mut buffer = canvas.into_raw();
    write_png(path, (width, height), &mut buffer, |root| {
        let font = ("sans-serif", 15).into_font();
        let header = [
            "tier".to_owned(),
            format!("reference ({reference_spp} spp)"),
            "error (|sRGB difference|)".to_owned(),
            "FLIP (LDR, magma)".to_owned(),
        ];
        for (column, text) in header.iter().enumerate() {
            let x = (margin + column as u32 * (tw + margin)) as i32;
            root.draw(&Text::new(
                text.clone(),
                (x, 12),
                ("sans-serif", 17).into_font(),
            ))
            .map_err(plot_error)?;
        }
        for (row, (cell, ..)) in rows.iter().enumerate() {
            let y = (40 + row as u32 * row_height + 4) as i32;
            let rmse = cell
                .rmse_srgb8
                .as_ref()
                .map_or("-".to_owned(), |s| format!("{:.2}", s.mean));
            let flip = cell
                .flip
                .as_ref()
                .map_or("-".to_owned(), |s| format!("{:.4}", s.mean));
            let ms = cell
                .ms_per_frame
                .as_ref()
                .map_or("-".to_owned(), |s| format!("{:.2}", s.mean));
            let text = format!(
                "{scene} / {}: rmse_srgb8 {rmse}, flip {flip}, {ms} ms per frame",
                cell.tier
            );
            root.draw(&Text::new(text, (margin as i32, y), font.clone()))
                .map_err(plot_error)?;
        }
        Ok(())
    })?;
    Ok(true)
}

/// A strip: `frames` side by side, each scaled to [`THUMBNAIL_WIDTH`] and labelled above,
/// under a `title` line; written to `path` as PNG.
pub fn strip(path: &Path, title: &str, frames: Vec<(String, RgbImage)>) -> Result<()> {
    register_font()?;
    let frames: Vec<(String, RgbImage)> = frames
        .into_iter()
        .map(|(label, image)| (label, scaled_thumbnail(image)))
        .collect();
    let (tw, th) = frames
        .first()
        .map_or((1, 1), |(_, image)| image.dimensions());
    let (margin, top) = (10u32, 50u32);
    let width = frames.len().max(1) as u32 * (tw + margin) + margin;
    let height = top + th + margin;
    let mut canvas = RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
    for (column, (_, image)) in frames.iter().enumerate() {
        let x = margin + column as u32 * (tw + margin);
        image::imageops::replace(&mut canvas, image, i64::from(x), i64::from(top));
    }
    let mut buffer = canvas.into_raw();
    write_png(path, (width, height), &mut buffer, |root| {
        root.draw(&Text::new(
            title.to_owned(),
            (margin as i32, 6),
            ("sans-serif", 15).into_font(),
        ))
        .map_err(plot_error)?;
        for (column, (label, _)) in frames.iter().enumerate() {
            let x = (margin + column as u32 * (tw + margin)) as i32;
            root.draw(&Text::new(
                label.clone(),
                (x, 28),
                ("sans-serif", 15).into_font(),
            ))
            .map_err(plot_error)?;
        }
        Ok(())
    })
}

/// The PNG at `path` scaled to [`THUMBNAIL_WIDTH`] (nearest neighbour when enlarging, so tiny
/// test images stay sharp), or `None` when it does not exist.
fn thumbnail(path: &Path) -> Result<Option<RgbImage>> {
    if !path.exists() {
        return Ok(None);
    }
    let image = image::open(path)
        .map_err(|e| anyhow!("reading {}: {e}", path.display()))?
        .to_rgb8();
    Ok(Some(scaled_thumbnail(image)))
}

/// `image` scaled to [`THUMBNAIL_WIDTH`] (nearest neighbour when enlarging).
fn scaled_thumbnail(image: RgbImage) -> RgbImage {
    let (w, h) = image.dimensions();
    let height = ((u64::from(h) * u64::from(THUMBNAIL_WIDTH)) / u64::from(w)).max(1) as u32;
    let filter = if w < THUMBNAIL_WIDTH {
        FilterType::Nearest
    } else {
        FilterType::Triangle
    };
    image::imageops::resize(&image, THUMBNAIL_WIDTH, height, filter)
}
