//! The μ*–σ plane of a Morris screening (Campolongo et al. 2007): one labelled point per
//! factor, μ* (how much the factor matters) across, σ (how much its effect depends on the other
//! factors or on itself) up, and the line σ = μ* above which a factor acts mostly through
//! interactions or non-linearity.

use std::path::Path;

use plotters::prelude::*;

use super::curve::{draw_legend, tick_format, COLOURS};
use super::damage_map::{save_png_atomic, PlotError};
use super::font;

const SIZE: (u32, u32) = (900, 640);

/// Writes the μ*–σ plot of `points` (factor name, μ*, σ) atomically; factors without both
/// numbers (every run of their moves failed) are left out.
pub fn write_morris_png(
    path: &Path,
    title: &str,
    points: &[(String, Option<f64>, Option<f64>)],
) -> Result<(), PlotError> {
    let draw = |msg: String| PlotError::Draw {
        path: path.to_path_buf(),
        msg,
    };
    let shown: Vec<(&str, f64, f64)> = points
        .iter()
        .filter_map(|(n, m, s)| Some((n.as_str(), (*m)?, (*s)?)))
        .filter(|(_, m, s)| m.is_finite() && s.is_finite())
        .collect();
    let top = shown.iter().map(|p| p.1.max(p.2)).fold(0.0, f64::max);
    let top = if top > 0.0 { 1.15 * top } else { 1.0 };
    font::ensure_font();
    let mut rgb = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let err = |e: DrawingAreaErrorKind<_>| draw(e.to_string());
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, (font::FAMILY, 22))
            .margin(14)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..top, 0.0..top)
            .map_err(err)?;
        let ticks = tick_format(&(0.0..top));
        chart
            .configure_mesh()
            .x_label_formatter(&ticks)
            .y_label_formatter(&ticks)
            .x_desc("μ* (mean |elementary effect|)")
            .y_desc("σ (standard deviation of the effects)")
            .label_style((font::FAMILY, 14))
            .axis_desc_style((font::FAMILY, 16))
            .light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(210, 210, 210))
            .draw()
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(0.0, 0.0), (top, top)],
                RGBColor(150, 150, 150).stroke_width(1),
            )))
            .map_err(err)?
            .label("σ = μ*")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(150, 150, 150)));
        // One colour and number per factor, named in the legend (full key paths do not fit
        // beside the points).
        for (k, &(name, m, s)) in shown.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            chart
                .draw_series(std::iter::once(Circle::new((m, s), 6, colour.filled())))
                .map_err(err)?
                .label(format!("{}: {name}", k + 1))
                .legend(move |(x, y)| Circle::new((x + 8, y), 5, colour.filled()));
            // The number beside the point, 8 pixels right and up.
            let number = EmptyElement::at((m, s))
                + Text::new(
                    format!("{}", k + 1),
                    (8, -18),
                    (font::FAMILY, 15).into_font(),
                );
            chart.draw_series(std::iter::once(number)).map_err(err)?;
        }
        draw_legend(&mut chart).map_err(err)?;
        root.present().map_err(err)?;
    }
    save_png_atomic(path, &rgb, SIZE.0, SIZE.1)
}
