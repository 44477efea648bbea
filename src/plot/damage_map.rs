//! PNG map of a scalar nodal field (damage, stretch, ...) for 2D runs.
//!
//! Nodes are rasterised directly into an RGB buffer (each node a filled
//! square of its cell size), which is fast enough for 10^6 nodes; plotters
//! only draws the axes, title and colour bar on top. Where several nodes fall
//! into one pixel the pixel shows their mean value, so thin features such as
//! a crack stay visible when nodes are smaller than a pixel.
//!
//! This file also hosts [`PlotError`] and the atomic PNG save shared with
//! `curve.rs`.

use std::fs;
use std::io;
use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::backend::DrawingBackend;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::font;
use crate::atomic_file as atomic;

/// Error of the PNG plot writers; every variant names the output file.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The data given to the plot is inconsistent (e.g. length mismatch).
    #[error("cannot plot '{path}': {msg}")]
    InvalidInput { path: PathBuf, msg: String },
    /// plotters failed while drawing or encoding.
    #[error("cannot draw '{path}': {msg}")]
    Draw { path: PathBuf, msg: String },
    /// The file system refused the write or rename.
    #[error("cannot write '{path}': {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
}

/// Appearance of a scalar map.
#[derive(Debug, Clone, Copy)]
pub struct MapStyle<'a> {
    /// Title drawn above the map.
    pub title: &'a str,
    /// Colour-bar label (quantity and unit).
    pub label: &'a str,
    /// Value mapped to the low end of the colour map (smaller values clamp).
    pub vmin: f64,
    /// Value mapped to the high end of the colour map (larger values clamp).
    pub vmax: f64,
    /// Requested image width in pixels. The image is made narrower only for
    /// very tall domains, to keep the 1:1 aspect within the height limit.
    pub width_px: u32,
    /// Line segments (metres) drawn over the nodes, e.g. the shape's boundary.
    pub outline: &'a [[[f64; 2]; 2]],
    /// Close the slivers an unstructured mesh leaves between node squares (field maps); off
    /// where the gaps are the point (a grid's node picture).
    pub fill_gaps: bool,
    /// Names of the horizontal and vertical axes ("x", "y"; other pairs for 3D slices).
    pub axis_names: [&'a str; 2],
}

/// An RGB8 image in memory plus where the data area lies in it.
pub(crate) struct RgbImage {
    pub width: u32,
    pub height: u32,
    /// Row-major RGB bytes, `3 * width * height`.
    pub data: Vec<u8>,
    /// Pixel x and y ranges of the node (plot) area.
    #[cfg_attr(not(test), allow(dead_code))] // read by the pixel tests
    pub plot_area: (Range<i32>, Range<i32>),
}

const BACKGROUND: [u8; 3] = [255, 255, 255];

/// Viridis sampled at 9 evenly spaced points; linear interpolation between
/// them is visually indistinguishable from the full table at plot sizes.
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

/// Colour of `t` in [0, 1] (clamped) on the viridis map.
pub fn colormap(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    std::array::from_fn(|k| (a[k] as f64 + f * (b[k] as f64 - a[k] as f64)).round() as u8)
}

/// Writes a PNG map of `values` at node positions `xy` (metres), each node a
/// square of side `cell_size[i]`. Axes are labelled in millimetres. NaN
/// values are left blank. The file is replaced atomically.
pub fn write_scalar_map_png(
    path: &Path,
    xy: &[[f64; 2]],
    cell_size: &[f64],
    values: &[f64],
    style: &MapStyle,
) -> Result<(), PlotError> {
    if xy.len() != values.len() || xy.len() != cell_size.len() {
        return Err(PlotError::InvalidInput {
            path: path.to_path_buf(),
            msg: format!(
                "{} positions, {} cell sizes and {} values must match",
                xy.len(),
                cell_size.len(),
                values.len()
            ),
        });
    }
    let img = render_scalar_map(xy, cell_size, values, style).map_err(|msg| PlotError::Draw {
        path: path.to_path_buf(),
        msg,
    })?;
    save_png_atomic(path, &img.data, img.width, img.height)
}

/// Encodes an RGB buffer as PNG at `path`, atomically. plotters only encodes
/// to a path (chosen by extension), so the temp file is `.NAME.tmp.png`.
pub(crate) fn save_png_atomic(
    path: &Path,
    rgb: &[u8],
    width: u32,
    height: u32,
) -> Result<(), PlotError> {
    let io_err = |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    };
    let tmp = atomic::temp_path(path, ".png").map_err(io_err)?;
    let encoded = {
        let mut backend = BitMapBackend::new(&tmp, (width, height));
        backend
            .blit_bitmap((0, 0), (width, height), rgb)
            .and_then(|()| backend.present())
            .map_err(|e| e.to_string())
        // Dropping a presented backend does not save again.
    };
    if let Err(msg) = encoded {
        let _ = fs::remove_file(&tmp);
        return Err(PlotError::Draw {
            path: path.to_path_buf(),
            msg,
        });
    }
    atomic::commit_temp(&tmp, path).map_err(io_err)
}

/// Pixel sizes derived from the requested width.
struct Layout {
    width: u32,
    height: u32,
    margin: u32,
    title_h: u32,
    x_label_h: u32,
    y_label_w: u32,
    bar_area_w: u32,
    bar_w: u32,
    fs_title: u32,
    fs_label: u32,
    fs_tick: u32,
}

impl Layout {
    fn new(width_px: u32, x_span: f64, y_span: f64) -> Self {
        let w = width_px.clamp(320, 8000);
        let fs_title = (w / 40).clamp(14, 28);
        let fs_label = (w / 55).clamp(12, 20);
        let fs_tick = (w / 65).clamp(10, 16);
        let margin = 10;
        let title_h = fs_title + 16;
        let x_label_h = fs_tick + fs_label + 24;
        let y_label_w = (fs_tick as f64 * 3.2) as u32 + fs_label + 14;
        let bar_w = (w / 45).max(14);
        let bar_area_w = 24 + bar_w + 8 + (fs_tick as f64 * 4.5) as u32 + fs_label + 16;
        let fixed_w = margin * 2 + y_label_w + bar_area_w;
        let fixed_h = title_h + x_label_h + margin;
        let mut plot_w = w.saturating_sub(fixed_w).max(50);
        // 1:1 aspect: plot height follows the data; clamp the total height
        // to 4x the width (shrinking the width instead to keep squares square)
        // and to at least 60 px of plot height (thin strips get stretched).
        let aspect = y_span / x_span;
        let max_plot_h = (4 * w).saturating_sub(fixed_h);
        let mut plot_h = (plot_w as f64 * aspect).round() as u32;
        if plot_h > max_plot_h {
            plot_h = max_plot_h;
            plot_w = ((plot_h as f64 / aspect).round() as u32).max(20);
        }
        let plot_h = plot_h.max(60);
        Layout {
            width: plot_w + fixed_w,
            height: plot_h + fixed_h,
            margin,
            title_h,
            x_label_h,
            y_label_w,
            bar_area_w,
            bar_w,
            fs_title,
            fs_label,
            fs_tick,
        }
    }
}

/// Data extent in metres: node squares included, degenerate spans widened.
fn extent(xy: &[[f64; 2]], cell_size: &[f64]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for (p, &c) in xy.iter().zip(cell_size) {
        let h = if c.is_finite() { 0.5 * c.abs() } else { 0.0 };
        for k in 0..2 {
            if p[k].is_finite() {
                lo[k] = lo[k].min(p[k] - h);
                hi[k] = hi[k].max(p[k] + h);
            }
        }
    }
    let mut out = [[0.0, 1e-3]; 2];
    for k in 0..2 {
        if lo[k] <= hi[k] {
            let span = hi[k] - lo[k];
            out[k] = if span > 0.0 {
                [lo[k], hi[k]]
            } else {
                let pad = if lo[k] != 0.0 {
                    lo[k].abs() * 0.05
                } else {
                    5e-4
                };
                [lo[k] - pad, hi[k] + pad]
            };
        }
    }
    // A degenerate axis borrows the other's span so the map is not a sliver.
    let span = |r: [f64; 2]| r[1] - r[0];
    for k in 0..2 {
        let other = span(out[1 - k]);
        if span(out[k]) < other * 1e-3 {
            let mid = 0.5 * (out[k][0] + out[k][1]);
            out[k] = [mid - 0.05 * other, mid + 0.05 * other];
        }
    }
    (out[0], out[1])
}

/// Compact number for colour-bar ticks: "0", "0.5", "1", "2.5e-4", ...
fn fmt_value(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".to_string()
    } else if (1e-3..1e4).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.2e}")
    }
}

/// Renders the complete map into an RGB buffer (no file I/O).
pub(crate) fn render_scalar_map(
    xy: &[[f64; 2]],
    cell_size: &[f64],
    values: &[f64],
    style: &MapStyle,
) -> Result<RgbImage, String> {
    font::ensure_font();
    let (xr, yr) = extent(xy, cell_size);
    let lay = Layout::new(style.width_px, xr[1] - xr[0], yr[1] - yr[0]);
    let (w, h) = (lay.width, lay.height);
    let mut data = BACKGROUND.repeat((w * h) as usize);
    let x_mm = xr[0] * 1e3..xr[1] * 1e3;
    let y_mm = yr[0] * 1e3..yr[1] * 1e3;
    let chart_w = w - lay.bar_area_w;

    // Pass 1: let plotters lay out the chart so our raster matches its axes.
    let plot_area = {
        let root = BitMapBackend::with_buffer(&mut data, (w, h)).into_drawing_area();
        let (chart_area, _) = root.split_horizontally(chart_w);
        let chart = ChartBuilder::on(&chart_area)
            .margin(lay.margin)
            .margin_top(lay.title_h)
            .x_label_area_size(lay.x_label_h)
            .y_label_area_size(lay.y_label_w)
            .build_cartesian_2d(x_mm.clone(), y_mm.clone())
            .map_err(|e| e.to_string())?;
        chart.plotting_area().get_pixel_range()
    };

    rasterise_nodes(
        &mut data, w, &plot_area, xr, yr, xy, cell_size, values, style,
    );
    let bar_x = plot_area.0.end + 24;
    let bar = (bar_x..bar_x + lay.bar_w as i32, plot_area.1.clone());
    fill_colour_bar(&mut data, w, &bar);

    // Pass 2: axes, labels, title and colour-bar annotations over the raster.
    {
        let root = BitMapBackend::with_buffer(&mut data, (w, h)).into_drawing_area();
        let (chart_area, _) = root.split_horizontally(chart_w);
        let mut chart = ChartBuilder::on(&chart_area)
            .margin(lay.margin)
            .margin_top(lay.title_h)
            .x_label_area_size(lay.x_label_h)
            .y_label_area_size(lay.y_label_w)
            .build_cartesian_2d(x_mm, y_mm)
            .map_err(|e| e.to_string())?;
        let tick_font = (font::FAMILY, lay.fs_tick).into_font();
        let label_font = (font::FAMILY, lay.fs_label).into_font();
        let (pw, ph) = (plot_area.0.len() as u32, plot_area.1.len() as u32);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels((pw / 90).clamp(2, 12) as usize)
            .y_labels((ph / 60).clamp(2, 12) as usize)
            .x_desc(format!("{} (mm)", style.axis_names[0]))
            .y_desc(format!("{} (mm)", style.axis_names[1]))
            .label_style(tick_font.clone())
            .axis_desc_style(label_font.clone())
            .draw()
            .map_err(|e| e.to_string())?;
        let draw = |e: Result<(), DrawingAreaErrorKind<_>>| e.map_err(|e| e.to_string());
        let frame = |r: &(Range<i32>, Range<i32>)| {
            Rectangle::new(
                [(r.0.start - 1, r.1.start - 1), (r.0.end, r.1.end)],
                BLACK.stroke_width(1),
            )
        };
        draw(root.draw(&frame(&plot_area)))?;
        draw(root.draw(&frame(&bar)))?;
        chart
            .draw_series(style.outline.iter().map(|[a, b]| {
                PathElement::new(
                    [(a[0] * 1e3, a[1] * 1e3), (b[0] * 1e3, b[1] * 1e3)],
                    RED.stroke_width(1),
                )
            }))
            .map_err(|e| e.to_string())?;

        // Title centred over the plot area, its font shrunk until a long title fits the
        // image (and then centred on the image).
        let (image_w, _) = root.dim_in_pixel();
        let room = image_w.saturating_sub(2 * lay.margin);
        let mut fs = lay.fs_title;
        let width = |fs: u32| {
            root.estimate_text_size(style.title, &(font::FAMILY, fs).into_font().color(&BLACK))
                .map(|(w, _)| w)
                .unwrap_or(0)
        };
        while fs > 10 && width(fs) > room {
            fs -= 1;
        }
        let centre = (plot_area.0.start + plot_area.0.end) / 2;
        let half = (width(fs) / 2) as i32;
        let centre =
            if centre - half < lay.margin as i32 || centre + half > (image_w - lay.margin) as i32 {
                image_w as i32 / 2
            } else {
                centre
            };
        let title_style = (font::FAMILY, fs)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let title_pos = (centre, (lay.margin + lay.title_h / 2) as i32 - 2);
        draw(root.draw(&Text::new(style.title, title_pos, title_style)))?;

        // Colour-bar ticks at vmin, midpoint and vmax.
        let tick_style = tick_font
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Center));
        let (top, bottom) = (bar.1.start, bar.1.end - 1);
        let mid = (style.vmin + style.vmax) / 2.0;
        let mut tick_w = 0;
        for (v, y) in [
            (style.vmax, top),
            (mid, (top + bottom) / 2),
            (style.vmin, bottom),
        ] {
            let text = fmt_value(v);
            let (tw, _) = root
                .estimate_text_size(&text, &tick_style)
                .map_err(|e| e.to_string())?;
            tick_w = tick_w.max(tw as i32);
            draw(root.draw(&PathElement::new(
                [(bar.0.end, y), (bar.0.end + 5, y)],
                BLACK.stroke_width(1),
            )))?;
            draw(root.draw(&Text::new(text, (bar.0.end + 8, y), tick_style.clone())))?;
        }
        // Bar label, vertical, to the right of the tick labels.
        let label_style = label_font
            .transform(FontTransform::Rotate270)
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center));
        // Just right of the widest tick label, but never past the image edge.
        let label_x = (bar.0.end + 8 + tick_w + 10 + lay.fs_label as i32 / 2)
            .min(w as i32 - lay.margin as i32 - lay.fs_label as i32 / 2);
        draw(root.draw(&Text::new(
            style.label,
            (label_x, (top + bottom) / 2),
            label_style,
        )))?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(RgbImage {
        width: w,
        height: h,
        data,
        plot_area,
    })
}

/// Fills the plot area with node squares, averaging nodes that share a pixel.
#[allow(clippy::too_many_arguments)]
fn rasterise_nodes(
    data: &mut [u8],
    img_w: u32,
    area: &(Range<i32>, Range<i32>),
    xr: [f64; 2],
    yr: [f64; 2],
    xy: &[[f64; 2]],
    cell_size: &[f64],
    values: &[f64],
    style: &MapStyle,
) {
    let (pw, ph) = (area.0.len(), area.1.len());
    if pw == 0 || ph == 0 {
        return;
    }
    let sx = pw as f64 / (xr[1] - xr[0]);
    let sy = ph as f64 / (yr[1] - yr[0]);
    let mut sum = vec![0f64; pw * ph];
    let mut count = vec![0u32; pw * ph];
    // Pixel index range covering [a, b) in area pixel units; at least the
    // pixel containing the centre so sub-pixel nodes still show up. A face shared by two
    // nodes lands on either side of a half pixel by rounding; widening both ends a little
    // lets the neighbours share that pixel instead of leaving it blank.
    const SLACK: f64 = 1e-6;
    let span = |a: f64, b: f64, n: usize| -> Option<(usize, usize)> {
        let c = 0.5 * (a + b);
        if !(c >= 0.0 && c < n as f64) {
            return None;
        }
        let lo = ((a - SLACK).round().max(0.0) as usize).min(n);
        let hi = ((b + SLACK).round().max(0.0) as usize).min(n);
        Some(if hi > lo {
            (lo, hi)
        } else {
            (c as usize, c as usize + 1)
        })
    };
    // Squares of the cell size tile a lattice exactly. Squares of √area at the centroids of
    // an unstructured mesh leave slivers between them: a second pass paints squares half as
    // large again, into the pixels still empty only, so no node covers another's colour.
    let varying = style.fill_gaps && cell_size.windows(2).any(|w| w[0] != w[1]);
    for (grow, only_empty) in [(1.0, false), (1.5, true)] {
        if only_empty && !varying {
            break;
        }
        let empty: Vec<bool> = if only_empty {
            count.iter().map(|&c| c == 0).collect()
        } else {
            Vec::new()
        };
        for ((p, &c), &v) in xy.iter().zip(cell_size).zip(values) {
            if v.is_nan() {
                continue;
            }
            let h = if c.is_finite() {
                0.5 * grow * c.abs()
            } else {
                0.0
            };
            let Some((x0, x1)) = span((p[0] - h - xr[0]) * sx, (p[0] + h - xr[0]) * sx, pw) else {
                continue;
            };
            // Pixel rows grow downwards while y grows upwards.
            let Some((y0, y1)) = span((yr[1] - p[1] - h) * sy, (yr[1] - p[1] + h) * sy, ph) else {
                continue;
            };
            for row in y0..y1 {
                let base = row * pw;
                for i in base + x0..base + x1 {
                    if only_empty && !empty[i] {
                        continue;
                    }
                    sum[i] += v;
                    count[i] += 1;
                }
            }
        }
    }
    let range = style.vmax - style.vmin;
    let to_t = |v: f64| {
        if range > 0.0 && range.is_finite() {
            (v - style.vmin) / range
        } else {
            0.5
        }
    };
    for row in 0..ph {
        let out_row = (area.1.start as usize + row) * img_w as usize + area.0.start as usize;
        for col in 0..pw {
            let i = row * pw + col;
            if count[i] > 0 {
                let rgb = colormap(to_t(sum[i] / count[i] as f64));
                let o = 3 * (out_row + col);
                data[o..o + 3].copy_from_slice(&rgb);
            }
        }
    }
}

/// Paints the vertical colour gradient (high values at the top).
fn fill_colour_bar(data: &mut [u8], img_w: u32, bar: &(Range<i32>, Range<i32>)) {
    let n = bar.1.len().max(2);
    for (k, row) in bar.1.clone().enumerate() {
        let rgb = colormap(1.0 - k as f64 / (n - 1) as f64);
        for col in bar.0.clone() {
            let o = 3 * (row as usize * img_w as usize + col as usize);
            data[o..o + 3].copy_from_slice(&rgb);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Square plate of n x n nodes with spacing dx and a damaged band.
    fn plate(n: usize, dx: f64) -> (Vec<[f64; 2]>, Vec<f64>, Vec<f64>) {
        let mut xy = Vec::with_capacity(n * n);
        let mut val = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                xy.push([(i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx]);
                // Crack along the middle row from the left edge to the centre.
                let crack = j == n / 2 && i < n / 2;
                val.push(if crack {
                    0.5
                } else {
                    0.02 * (i as f64 / n as f64)
                });
            }
        }
        (xy, vec![dx; n * n], val)
    }

    fn style() -> MapStyle<'static> {
        MapStyle {
            outline: &[],
            fill_gaps: true,
            axis_names: ["x", "y"],
            title: "Damage, step 1000",
            label: "damage (-)",
            vmin: 0.0,
            vmax: 1.0,
            width_px: 800,
        }
    }

    fn pixel(img: &RgbImage, x: i32, y: i32) -> [u8; 3] {
        let o = 3 * (y as usize * img.width as usize + x as usize);
        [img.data[o], img.data[o + 1], img.data[o + 2]]
    }

    #[test]
    fn colormap_ends_and_clamping() {
        assert_eq!(colormap(0.0), VIRIDIS[0]);
        assert_eq!(colormap(1.0), VIRIDIS[8]);
        assert_eq!(colormap(-3.0), VIRIDIS[0]);
        assert_eq!(colormap(7.0), VIRIDIS[8]);
        assert_eq!(colormap(0.5), VIRIDIS[4]);
    }

    /// Node squares smaller than their spacing (as √area squares of an unstructured mesh are
    /// in places) leave background slivers, which the gap-filling pass closes.
    #[test]
    fn gaps_between_uneven_node_squares_are_filled() {
        let (xy, _, val) = plate(30, 1e-3);
        let cell: Vec<f64> = (0..xy.len())
            .map(|i| if i % 2 == 0 { 0.7e-3 } else { 0.75e-3 })
            .collect();
        let background = |fill_gaps| {
            let s = MapStyle {
                fill_gaps,
                ..style()
            };
            let img = render_scalar_map(&xy, &cell, &val, &s).unwrap();
            let (xs, ys) = img.plot_area.clone();
            // The interior, away from the plate's edge.
            let (dx, dy) = (xs.len() as i32 / 10, ys.len() as i32 / 10);
            let mut n = 0;
            for y in ys.start + dy..ys.end - dy {
                for x in xs.start + dx..xs.end - dx {
                    n += (pixel(&img, x, y) == BACKGROUND) as usize;
                }
            }
            n
        };
        assert!(background(false) > 1000, "the test needs gaps to close");
        assert_eq!(background(true), 0);
    }

    /// Where a cell face falls on half a pixel, rounding must not leave a pixel row or column
    /// to neither neighbour (a white line through the map).
    #[test]
    fn lattices_tile_the_plot_area_at_every_size() {
        for n in 4..48 {
            let (xy, cell, val) = plate(n, 0.4e-3);
            let img = render_scalar_map(&xy, &cell, &val, &style()).unwrap();
            let (xs, ys) = img.plot_area.clone();
            let blank = ys
                .flat_map(|y| xs.clone().map(move |x| (x, y)))
                .filter(|&(x, y)| pixel(&img, x, y) == BACKGROUND)
                .count();
            assert_eq!(blank, 0, "{n} × {n} nodes");
        }
    }

    #[test]
    fn plot_area_is_filled_with_map_colours() {
        let (xy, cell, val) = plate(50, 1e-3);
        let img = render_scalar_map(&xy, &cell, &val, &style()).unwrap();
        assert_eq!(img.data.len(), 3 * (img.width * img.height) as usize);
        let (xs, ys) = img.plot_area.clone();
        // 1:1 aspect for a square plate.
        assert!(
            (xs.len() as i32 - ys.len() as i32).abs() <= 2,
            "{xs:?} {ys:?}"
        );
        // Every pixel of the plate interior is coloured (not background).
        let mut background = 0;
        for y in ys.clone().step_by(7) {
            for x in xs.clone().step_by(7) {
                if pixel(&img, x, y) == BACKGROUND {
                    background += 1;
                }
            }
        }
        assert_eq!(background, 0);
        // Undamaged corner is dark (low end), crack is mid-map green/teal.
        let corner = pixel(&img, xs.end - 3, ys.start + 3);
        assert!(corner[0] < 100 && corner[2] > 60, "{corner:?}");
        let crack = pixel(
            &img,
            xs.start + xs.len() as i32 / 4,
            // Centre of node row 25 of 50, counted from the bottom.
            ys.start + (ys.len() as f64 * 24.5 / 50.0) as i32,
        );
        assert_eq!(crack, colormap(0.5));
        // Colour bar: top is the high end of the map.
        let bar_top = pixel(&img, xs.end + 24 + 5, ys.start + 1);
        assert!(bar_top[0] > 200 && bar_top[1] > 200, "{bar_top:?}");
        // The title/label margins are background.
        assert_eq!(pixel(&img, 2, 2), BACKGROUND);
    }

    #[test]
    fn writes_png_and_rejects_mismatch() {
        let dir = atomic::test_dir("map");
        let path = dir.join("damage.png");
        let (xy, cell, val) = plate(40, 2.5e-4);
        write_scalar_map_png(&path, &xy, &cell, &val, &style()).unwrap();
        let bytes = fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert!(bytes.len() > 5_000, "{} bytes", bytes.len());
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1, "no temp file left");

        let err = write_scalar_map_png(&path, &xy, &cell, &val[1..], &style()).unwrap_err();
        assert!(matches!(err, PlotError::InvalidInput { .. }));
        assert!(err.to_string().contains("damage.png"), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let s = MapStyle {
            vmin: 1.0,
            vmax: 1.0,
            width_px: 10,
            ..style()
        };
        render_scalar_map(&[], &[], &[], &s).unwrap();
        render_scalar_map(&[[0.0, 0.0]], &[0.0], &[f64::NAN], &s).unwrap();
        // A single row of nodes (zero y extent besides the cell size).
        let xy: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 1e-3, 0.0]).collect();
        render_scalar_map(&xy, &[1e-3; 100], &[0.3; 100], &style()).unwrap();
        // Very tall domain: height clamped to 4x width, squares kept square.
        let xy: Vec<[f64; 2]> = (0..1000).map(|i| [0.0, i as f64 * 1e-3]).collect();
        let img = render_scalar_map(&xy, &[1e-3; 1000], &[0.3; 1000], &style()).unwrap();
        assert!(img.height <= 4 * 800 + 1);
    }

    /// Writes `sample_map.png` into the crate directory for a visual check:
    /// `cargo test --release -- --ignored write_sample_map`.
    #[test]
    #[ignore]
    fn write_sample_map() {
        // 2:1 plate, 40 mm x 20 mm, with a hole and a crack from the left edge.
        let dx = 1e-4;
        let (nx, ny) = (400, 200);
        let (mut xy, mut val) = (Vec::new(), Vec::new());
        for j in 0..ny {
            for i in 0..nx {
                let (x, y) = ((i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx);
                let (hx, hy) = (x - 0.028, y - 0.01);
                if hx * hx + hy * hy < 0.003 * 0.003 {
                    continue;
                }
                let d_crack = (y - 0.01).abs();
                let along = x < 0.018;
                let d = if along {
                    (1.0 - d_crack / 4e-4).max(0.0)
                } else {
                    0.0
                };
                xy.push([x, y]);
                val.push(d.max(0.05 * x / 0.04));
            }
        }
        let cell = vec![dx; xy.len()];
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("sample_map.png");
        let s = MapStyle {
            width_px: 1000,
            ..style()
        };
        write_scalar_map_png(&path, &xy, &cell, &val, &s).unwrap();
    }

    #[test]
    fn timing_1e5_nodes() {
        let (xy, cell, val) = plate(317, 1e-4); // ~10^5 nodes
        let dir = atomic::test_dir("map-timing");
        let path = dir.join("big.png");
        let t = std::time::Instant::now();
        let img = render_scalar_map(
            &xy,
            &cell,
            &val,
            &MapStyle {
                width_px: 1000,
                ..style()
            },
        )
        .unwrap();
        let render = t.elapsed();
        write_scalar_map_png(
            &path,
            &xy,
            &cell,
            &val,
            &MapStyle {
                width_px: 1000,
                ..style()
            },
        )
        .unwrap();
        let total = t.elapsed() - render;
        println!(
            "scalar map, {} nodes, {}x{} px: render {:.1} ms, render+PNG write {:.1} ms",
            xy.len(),
            img.width,
            img.height,
            render.as_secs_f64() * 1e3,
            total.as_secs_f64() * 1e3
        );
        fs::remove_dir_all(&dir).unwrap();
    }
}
