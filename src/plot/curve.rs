//! PNG line plot of one or more (x, y) series with a legend, e.g. load versus
//! displacement or energy versus time from the history table.
//! (Lines are `PathElement`s: plotters' `LineSeries` needs a feature we do
//! not enable.)

use std::ops::Range;
use std::path::Path;

use plotters::prelude::*;

use super::damage_map::{save_png_atomic, PlotError};
use super::font;

/// Image size of curve plots in pixels.
const SIZE: (u32, u32) = (900, 560);

/// Distinct line colours (matplotlib's "tab10"), cycled.
pub(crate) const COLOURS: [RGBColor; 10] = [
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

/// `write_curves_png` for series that own their names and points.
pub fn write_named_curves_png(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<(), PlotError> {
    let refs: Vec<(&str, &[(f64, f64)])> = series
        .iter()
        .map(|(n, p)| (n.as_str(), p.as_slice()))
        .collect();
    write_curves_png(path, title, x_label, y_label, &refs)
}

/// Writes a line plot of `series` (name, points) with a legend, atomically.
///
/// Axis ranges cover all finite points; non-finite points break a line.
/// Empty input or constant data still gives a valid (if empty) plot.
pub fn write_curves_png(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(&str, &[(f64, f64)])],
) -> Result<(), PlotError> {
    write_curves_and_points_png(path, title, x_label, y_label, series, &[])
}

/// `write_curves_png` with sets of points drawn as marks, not lines (e.g. a paper's values
/// beside the computed curves).
pub fn write_curves_and_points_png(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(&str, &[(f64, f64)])],
    points: &[(&str, &[(f64, f64)])],
) -> Result<(), PlotError> {
    let rgb =
        render_curves(title, x_label, y_label, series, points).map_err(|msg| PlotError::Draw {
            path: path.to_path_buf(),
            msg,
        })?;
    save_png_atomic(path, &rgb, SIZE.0, SIZE.1)
}

/// `lo..hi` of finite values, widened if empty or degenerate and padded.
fn axis_range(values: impl Iterator<Item = f64>, pad_frac: f64) -> Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return 0.0..1.0;
    }
    let span = hi - lo;
    if span <= f64::EPSILON * lo.abs().max(hi.abs()) || span == 0.0 {
        // All equal: centre the value in a window proportional to it.
        let half = if lo != 0.0 { 0.1 * lo.abs() } else { 1.0 };
        return lo - half..hi + half;
    }
    lo - pad_frac * span..hi + pad_frac * span
}

/// Tick labels readable at the axis's scale: plain decimals with enough digits for the span,
/// or scientific notation for very small or large values.
pub(crate) fn tick_format(range: &Range<f64>) -> impl Fn(&f64) -> String {
    let span = (range.end - range.start).abs();
    let size = range.start.abs().max(range.end.abs());
    let scientific = size > 0.0 && !(1e-2..1e5).contains(&size);
    let decimals = if span > 0.0 {
        (-(span / 5.0).log10().floor()).clamp(0.0, 6.0) as usize
    } else {
        2
    };
    move |v: &f64| {
        if scientific {
            format!("{v:.2e}")
        } else {
            format!("{v:.decimals$}")
        }
    }
}

/// Renders the plot into an RGB buffer of size [`SIZE`].
pub(crate) fn render_curves(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(&str, &[(f64, f64)])],
    points: &[(&str, &[(f64, f64)])],
) -> Result<Vec<u8>, String> {
    font::ensure_font();
    let all = || series.iter().chain(points).flat_map(|(_, pts)| pts.iter());
    let xr = axis_range(all().map(|p| p.0), 0.0);
    let yr = axis_range(all().map(|p| p.1), 0.05);

    let mut rgb = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let err = |e: DrawingAreaErrorKind<_>| e.to_string();
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (x_ticks, y_ticks) = (tick_format(&xr), tick_format(&yr));
        let mut chart = ChartBuilder::on(&root)
            .caption(title, (font::FAMILY, 22))
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(xr, yr)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_label_formatter(&x_ticks)
            .y_label_formatter(&y_ticks)
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style((font::FAMILY, 14))
            .axis_desc_style((font::FAMILY, 16))
            .light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(210, 210, 210))
            .draw()
            .map_err(err)?;

        for (k, (name, pts)) in series.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            let style = colour.stroke_width(2);
            // Split at non-finite points so gaps show instead of wild lines.
            let mut runs = pts
                .split(|p| !(p.0.is_finite() && p.1.is_finite()))
                .filter(|r| !r.is_empty())
                .peekable();
            if runs.peek().is_none() {
                // Still list the series in the legend.
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        Vec::<(f64, f64)>::new(),
                        style,
                    )))
                    .map_err(err)?
                    .label(*name)
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
                continue;
            }
            let mut first = true;
            for run in runs {
                // One element per segment: joined thick paths draw long miter spikes where a
                // curve turns sharply (a load drop).
                let ann = chart
                    .draw_series(
                        run.windows(2)
                            .map(|w| PathElement::new(w.to_vec(), style))
                            .chain((run.len() == 1).then(|| PathElement::new(run.to_vec(), style))),
                    )
                    .map_err(err)?;
                if first {
                    ann.label(*name)
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
                    first = false;
                }
                // A lone point is invisible as a line: mark it.
                if run.len() == 1 {
                    chart
                        .draw_series(std::iter::once(Circle::new(run[0], 3, colour.filled())))
                        .map_err(err)?;
                }
            }
        }
        for (k, (name, pts)) in points.iter().enumerate() {
            // Black and dark grey crosses: apart from every line colour.
            let colour = [BLACK, RGBColor(110, 110, 110)][k % 2];
            let style = colour.stroke_width(2);
            let finite = pts.iter().filter(|p| p.0.is_finite() && p.1.is_finite());
            chart
                .draw_series(finite.map(|&p| Cross::new(p, 6, style)))
                .map_err(err)?
                .label(*name)
                .legend(move |(x, y)| Cross::new((x + 10, y), 6, style));
        }
        if !series.is_empty() || !points.is_empty() {
            draw_legend(&mut chart).map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(rgb)
}

/// The series' legend in the chart's upper left corner, on a white box (every curve plot).
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((font::FAMILY, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atomic_file as atomic;
    use std::fs;

    fn count_colour(rgb: &[u8], c: RGBColor) -> usize {
        rgb.chunks_exact(3)
            .filter(|p| p[0] == c.0 && p[1] == c.1 && p[2] == c.2)
            .count()
    }

    #[test]
    fn writes_png_with_lines() {
        let dir = atomic::test_dir("curve");
        let path = dir.join("load.png");
        let a: Vec<(f64, f64)> = (0..200)
            .map(|i| (i as f64 * 1e-6, (i as f64 * 0.05).sin()))
            .collect();
        let b: Vec<(f64, f64)> = (0..200).map(|i| (i as f64 * 1e-6, 0.5)).collect();
        let series: [(&str, &[(f64, f64)]); 2] = [("sin", &a), ("const", &b)];
        write_curves_png(&path, "Energy", "time (s)", "energy (J)", &series).unwrap();
        let bytes = fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert!(bytes.len() > 5_000, "{} bytes", bytes.len());
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1, "no temp file left");

        let rgb = render_curves("Energy", "time (s)", "energy (J)", &series, &[]).unwrap();
        assert!(count_colour(&rgb, COLOURS[0]) > 500, "first series drawn");
        assert!(count_colour(&rgb, COLOURS[1]) > 500, "second series drawn");
        fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes `sample_curve.png` into the crate directory for a visual check:
    /// `cargo test --release -- --ignored write_sample_curve`.
    #[test]
    #[ignore]
    fn write_sample_curve() {
        let load: Vec<(f64, f64)> = (0..=300)
            .map(|i| {
                let u = i as f64 * 1e-6; // displacement (m)
                let f = if u < 2e-4 {
                    5e7 * u
                } else {
                    1e4 * (-(u - 2e-4) / 3e-5).exp()
                };
                (u * 1e3, f * 1e-3) // mm, kN
            })
            .collect();
        let elastic: Vec<(f64, f64)> = (0..=30)
            .map(|i| (i as f64 * 1e-2, 50.0 * i as f64 * 1e-2))
            .collect();
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("sample_curve.png");
        let series: [(&str, &[(f64, f64)]); 2] =
            [("reaction force", &load), ("linear elastic", &elastic)];
        write_curves_png(
            &path,
            "Load vs displacement",
            "displacement (mm)",
            "force (kN)",
            &series,
        )
        .unwrap();
    }

    #[test]
    fn degenerate_inputs_are_handled() {
        let constant = [(1.0, 3.0), (1.0, 3.0)];
        let zero = [(0.0, 0.0)];
        let gaps = [(0.0, 1.0), (1.0, f64::NAN), (2.0, 2.0), (3.0, 2.5)];
        let empty: [(f64, f64); 0] = [];
        render_curves("t", "x", "y", &[], &[]).unwrap();
        render_curves("t", "x", "y", &[("empty", &empty)], &[]).unwrap();
        render_curves("t", "x", "y", &[("c", &constant)], &[("p", &constant)]).unwrap();
        render_curves("t", "x", "y", &[("z", &zero)], &[]).unwrap();
        render_curves("t", "x", "y", &[("g", &gaps), ("e", &empty)], &[]).unwrap();
        let r = axis_range([3.0, 3.0].into_iter(), 0.05);
        assert!(
            (r.start - 2.7).abs() < 1e-12 && (r.end - 3.3).abs() < 1e-12,
            "{r:?}"
        );
        assert_eq!(axis_range(std::iter::empty(), 0.05), 0.0..1.0);
        assert_eq!(axis_range([0.0].into_iter(), 0.05), -1.0..1.0);
    }
}
