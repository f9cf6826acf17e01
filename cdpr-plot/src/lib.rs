//! # cdpr-plot
//!
//! The pictures of the host tools (`cdpr`, `hal-sim`): line plots (tension
//! profiles with their limits, robustness, volume against payload) as PNG
//! and SVG, and workspace slices as PNG.
//!
//! Text is drawn with DejaVu Sans embedded in the binary (the `dejavu`
//! crate, rendered by plotters' `ab_glyph` backend), so no system font is
//! needed; PNG files are encoded with the `png` crate.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::error::Error;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

/// A plot could not be drawn or encoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlotError(
    /// What the drawing or encoding backend reported.
    pub String,
);

impl std::fmt::Display for PlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "drawing failed: {}", self.0)
    }
}

impl Error for PlotError {}

/// The font family name the plots use.
const FONT: &str = "sans-serif";

/// Registers the embedded font (once per process).
pub fn init_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // DejaVu Sans is a valid TrueType font; registration cannot fail.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Distinguishable line colours (Tableau 10 and two more), one per cable.
pub const PALETTE: [RGBColor; 12] = [
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
    RGBColor(0, 0, 128),
    RGBColor(128, 0, 0),
];

/// One named curve, possibly broken into several pieces (gaps where a
/// sample had no value).
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Colour.
    pub color: RGBColor,
    /// Continuous pieces of `(x, y)` points.
    pub pieces: Vec<Vec<(f64, f64)>>,
    /// Draw a marker at every point.
    pub markers: bool,
    /// Line width, pixels.
    pub width: u32,
}

impl Series {
    /// A series from samples where `None` breaks the line.
    pub fn from_samples(
        name: impl Into<String>,
        color: RGBColor,
        samples: impl IntoIterator<Item = (f64, Option<f64>)>,
    ) -> Self {
        let mut pieces = vec![];
        let mut current = vec![];
        for (x, y) in samples {
            match y {
                Some(y) if y.is_finite() => current.push((x, y)),
                _ => {
                    if !current.is_empty() {
                        pieces.push(std::mem::take(&mut current));
                    }
                }
            }
        }
        if !current.is_empty() {
            pieces.push(current);
        }
        Self { name: name.into(), color, pieces, markers: false, width: 2 }
    }
}

/// A line plot.
#[derive(Debug, Clone, Default)]
pub struct LinePlot {
    /// Caption.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// The curves.
    pub series: Vec<Series>,
    /// Dashed horizontal lines with a label (e.g. `t_min`, `t_max`).
    pub hlines: Vec<(f64, String)>,
    /// Shaded `x` intervals (e.g. where no tension was found).
    pub bands: Vec<(f64, f64)>,
    /// Legend text of the shaded intervals.
    pub band_label: String,
    /// Force the vertical range to include zero.
    pub include_zero: bool,
}

/// Keeps at most about `max` points of a piece: per bucket its first point
/// and its smallest and largest value, so that spikes survive.
pub fn decimate(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 8 {
        return points.to_vec();
    }
    let bucket = points.len().div_ceil(max / 3);
    let mut out = Vec::with_capacity(max + 3);
    for chunk in points.chunks(bucket) {
        let lo =
            chunk.iter().enumerate().min_by(|a, b| a.1 .1.total_cmp(&b.1 .1)).map(|(i, _)| i).unwrap_or(0);
        let hi =
            chunk.iter().enumerate().max_by(|a, b| a.1 .1.total_cmp(&b.1 .1)).map(|(i, _)| i).unwrap_or(0);
        let mut idx = vec![0, lo, hi];
        idx.sort_unstable();
        idx.dedup();
        out.extend(idx.into_iter().map(|i| chunk[i]));
    }
    if let Some(&last) = points.last() {
        if out.last() != Some(&last) {
            out.push(last);
        }
    }
    out
}

fn draw_err(e: impl std::fmt::Display) -> PlotError {
    PlotError(e.to_string())
}

/// Encodes an RGB8 buffer as PNG.
pub fn encode_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(draw_err)?;
        writer.write_image_data(rgb).map_err(draw_err)?;
        writer.finish().map_err(draw_err)?;
    }
    Ok(out)
}

/// Renders with `draw` into a PNG of `size` pixels.
pub fn render_png<F>(size: (u32, u32), draw: F) -> Result<Vec<u8>, PlotError>
where
    F: FnOnce(DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), Box<dyn Error>>,
{
    init_fonts();
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        draw(root).map_err(draw_err)?;
    }
    encode_png(&buf, size.0, size.1)
}

/// Renders with `draw` into an SVG document of `size` pixels.
pub fn render_svg<F>(size: (u32, u32), draw: F) -> Result<String, PlotError>
where
    F: FnOnce(DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), Box<dyn Error>>,
{
    init_fonts();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, size).into_drawing_area();
        draw(root).map_err(draw_err)?;
    }
    Ok(s)
}

fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

/// The axis ranges, and which horizontal lines are drawn: a limit far
/// outside the data (more than the data's span beyond it) would squash the
/// curves, so it is listed in the legend as off scale instead.
fn ranges(plot: &LinePlot) -> ((f64, f64), (f64, f64), Vec<bool>) {
    let pts = plot.series.iter().flat_map(|s| s.pieces.iter().flatten());
    let (mut x0, mut x1, mut y0, mut y1) =
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    for &(a, b) in &plot.bands {
        x0 = x0.min(a);
        x1 = x1.max(b);
    }
    let data = y0.is_finite() && y1.is_finite();
    let span = if data { (y1 - y0).max(y1.abs() * 0.1) } else { 0.0 };
    let shown: Vec<bool> =
        plot.hlines.iter().map(|(y, _)| !data || (*y >= y0 - span && *y <= y1 + span)).collect();
    for ((y, _), show) in plot.hlines.iter().zip(&shown) {
        if *show {
            y0 = y0.min(*y);
            y1 = y1.max(*y);
        }
    }
    if plot.include_zero {
        y0 = y0.min(0.0);
        y1 = y1.max(0.0);
    }
    if !x0.is_finite() || !x1.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    if !y0.is_finite() || !y1.is_finite() {
        (y0, y1) = (0.0, 1.0);
    }
    if x1 - x0 <= 0.0 {
        (x0, x1) = (x0 - 0.5, x1 + 0.5);
    }
    let span = if y1 - y0 > 0.0 { y1 - y0 } else { y0.abs().max(1.0) };
    ((x0, x1), (y0 - 0.06 * span, y1 + 0.06 * span), shown)
}

/// Draws a line plot on any backend: the chart on the left, the legend in
/// a strip on the right.
pub fn draw_line_plot<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    plot: &LinePlot,
) -> Result<(), Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (w, _) = root.dim_in_pixel();
    let longest = plot
        .series
        .iter()
        .map(|s| s.name.chars().count())
        .chain([plot.band_label.chars().count(), 6])
        .chain(plot.hlines.iter().map(|(_, l)| l.chars().count() * 3 / 4 + 10))
        .max()
        .unwrap_or(6) as u32;
    let legend_w = (longest * 8 + 44).min(w / 3);
    let (left, right) = root.split_horizontally(w - legend_w);
    let ((x0, x1), (y0, y1), shown) = ranges(plot);
    let mut chart = ChartBuilder::on(&left)
        .caption(&plot.title, font(20.0))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .label_style(font(13.0))
        .axis_desc_style(font(15.0))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(210, 210, 210))
        .draw()?;
    let band_color = RGBColor(255, 200, 200);
    for &(a, b) in &plot.bands {
        chart.draw_series(std::iter::once(Rectangle::new([(a, y0), (b, y1)], band_color.filled())))?;
    }
    for s in &plot.series {
        for piece in &s.pieces {
            let pts = decimate(piece, 4000);
            chart.draw_series(LineSeries::new(pts.iter().copied(), s.color.stroke_width(s.width)))?;
            if s.markers {
                chart.draw_series(
                    pts.iter().map(|&p| Circle::new(p, 4, s.color.filled())).collect::<Vec<_>>(),
                )?;
            }
        }
    }
    for ((y, label), _) in plot.hlines.iter().zip(&shown).filter(|(_, s)| **s) {
        chart.draw_series(DashedLineSeries::new(vec![(x0, *y), (x1, *y)], 10, 6, BLACK.stroke_width(2)))?;
        let (px, py) = chart.backend_coord(&(x0, *y));
        let width = (label.chars().count() as f64 * 8.0) as i32 + 8;
        left.draw(&Rectangle::new([(px + 4, py - 20), (px + 4 + width, py - 3)], WHITE.mix(0.85).filled()))?;
        left.draw(&Text::new(label.clone(), (px + 8, py - 19), font(14.0)))?;
    }
    // Legend strip.
    let mut y = 50;
    let mut entry = |color: Option<RGBColor>, filled: bool, text: &str| -> Result<(), Box<dyn Error>> {
        match color {
            Some(c) if filled => {
                right.draw(&Rectangle::new([(4, y - 6), (28, y + 6)], c.filled()))?;
            }
            Some(c) => {
                right.draw(&PathElement::new(vec![(4, y), (28, y)], c.stroke_width(3)))?;
            }
            None => {
                right.draw(&PathElement::new(vec![(4, y), (12, y)], BLACK.stroke_width(2)))?;
                right.draw(&PathElement::new(vec![(18, y), (28, y)], BLACK.stroke_width(2)))?;
            }
        }
        right.draw(&Text::new(text.to_string(), (34, y - 8), font(14.0)))?;
        y += 22;
        Ok(())
    };
    for s in &plot.series {
        entry(Some(s.color), false, &s.name)?;
    }
    if shown.iter().any(|s| *s) {
        entry(None, false, "limits")?;
    }
    if !plot.bands.is_empty() {
        entry(Some(band_color), true, &plot.band_label)?;
    }
    for ((_, label), _) in plot.hlines.iter().zip(&shown).filter(|(_, s)| !**s) {
        right.draw(&Text::new(format!("{label} (off scale)"), (4, y - 8), font(12.0)))?;
        y += 22;
    }
    root.present()?;
    Ok(())
}

/// A line plot as PNG bytes and SVG text.
pub fn line_plot(plot: &LinePlot, size: (u32, u32)) -> Result<(Vec<u8>, String), PlotError> {
    let png = render_png(size, |root| draw_line_plot(root, plot))?;
    let svg = render_svg(size, |root| draw_line_plot(root, plot))?;
    Ok((png, svg))
}

/// One slice of a workspace grid: cell values (robustness, `NaN` where no
/// tension was found) over a rectangle.
#[derive(Debug, Clone)]
pub struct Slice {
    /// Panel caption.
    pub title: String,
    /// Horizontal range of the rectangle and the number of cells along it.
    pub x: (f64, f64, usize),
    /// Vertical range and number of cells.
    pub y: (f64, f64, usize),
    /// Row-major values, `x` fastest.
    pub values: Vec<f32>,
    /// Points to mark (anchors projected on the slice).
    pub marks: Vec<(f64, f64)>,
}

/// A perceptually ordered colour map (viridis, 5 stops), `v` in `[0, 1]`.
pub fn viridis(v: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    let f = v * 4.0;
    let i = (f.floor() as usize).min(3);
    let t = f - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * t).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Workspace slices side by side (PNG), coloured by robustness from 0 to
/// `scale` (larger values get the top colour); grey cells have no feasible
/// tension.
pub fn slices_png(
    title: &str,
    axes: (&str, &str),
    slices: &[Slice],
    scale: f64,
) -> Result<Vec<u8>, PlotError> {
    let cols = slices.len().clamp(1, 3);
    let rows = slices.len().div_ceil(cols).max(1);
    let (pw, ph) = if slices.len() == 1 { (620u32, 560u32) } else { (460u32, 400u32) };
    let title_width = title.chars().count() as u32 * 12 + 40;
    let size = ((pw * cols as u32 + 130).max(title_width), ph * rows as u32 + 50);
    render_png(size, |root| {
        root.fill(&WHITE)?;
        let root = root.titled(title, font(22.0))?;
        let (w, _) = root.dim_in_pixel();
        let (panels, bar) = root.split_horizontally(w - 130);
        let areas = panels.split_evenly((rows, cols));
        let infeasible = RGBColor(225, 225, 225);
        for (slice, area) in slices.iter().zip(&areas) {
            let (x0, x1, nx) = slice.x;
            let (y0, y1, ny) = slice.y;
            let (hx, hy) = ((x1 - x0) / nx as f64, (y1 - y0) / ny as f64);
            let mut chart = ChartBuilder::on(area)
                .caption(&slice.title, font(16.0))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(x0..x1, y0..y1)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(format!("{} [m]", axes.0))
                .y_desc(format!("{} [m]", axes.1))
                .label_style(font(12.0))
                .axis_desc_style(font(13.0))
                .draw()?;
            chart.draw_series((0..ny).flat_map(|j| {
                (0..nx).map(move |i| {
                    let v = slice.values[j * nx + i] as f64;
                    let color = if v.is_finite() { viridis(v / scale) } else { infeasible };
                    let (cx, cy) = (x0 + i as f64 * hx, y0 + j as f64 * hy);
                    Rectangle::new([(cx, cy), (cx + hx, cy + hy)], color.filled())
                })
            }))?;
            chart.draw_series(
                slice
                    .marks
                    .iter()
                    .filter(|&&(x, y)| x >= x0 && x <= x1 && y >= y0 && y <= y1)
                    .map(|&p| Circle::new(p, 5, BLACK.filled())),
            )?;
        }
        // Colour bar.
        let (top, bottom) = (60i32, 300i32);
        for k in top..bottom {
            let v = (bottom - k) as f64 / (bottom - top) as f64;
            bar.draw(&PathElement::new(vec![(20, k), (45, k)], viridis(v).stroke_width(1)))?;
        }
        bar.draw(&Text::new("robustness", (5, top - 40), font(13.0)))?;
        bar.draw(&Text::new("[N]", (5, top - 22), font(13.0)))?;
        bar.draw(&Text::new(format!(">= {scale:.3}"), (50, top - 6), font(12.0)))?;
        bar.draw(&Text::new("0", (50, bottom - 6), font(12.0)))?;
        bar.draw(&Rectangle::new([(20, bottom + 20), (45, bottom + 40)], infeasible.filled()))?;
        bar.draw(&Text::new("no", (50, bottom + 16), font(12.0)))?;
        bar.draw(&Text::new("tension", (50, bottom + 30), font(12.0)))?;
        bar.draw(&Text::new("anchor", (50, bottom + 62), font(12.0)))?;
        bar.draw(&Circle::new((32, bottom + 70), 5, BLACK.filled()))?;
        root.present()?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_ends_and_extremes() {
        let pts: Vec<(f64, f64)> =
            (0..10_000).map(|i| (i as f64, if i == 5_123 { 100.0 } else { 0.0 })).collect();
        let d = decimate(&pts, 600);
        assert!(d.len() <= 700);
        assert_eq!(d[0], pts[0]);
        assert_eq!(*d.last().unwrap(), *pts.last().unwrap());
        assert!(d.contains(&(5_123.0, 100.0)));
    }

    #[test]
    fn png_and_svg_are_produced() {
        let plot = LinePlot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series::from_samples(
                "a",
                PALETTE[0],
                (0..10).map(|i| (i as f64, (i != 4).then_some(i as f64))),
            )],
            hlines: vec![(1.0, "one".into())],
            bands: vec![(3.5, 4.5)],
            band_label: "gap".into(),
            include_zero: true,
        };
        let (png, svg) = line_plot(&plot, (400, 300)).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert!(svg.starts_with("<svg"));
    }
}
