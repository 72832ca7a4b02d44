//! PNG plots of the CLI's studies: log-log line charts drawn with plotters. Text is drawn with
//! a TrueType font registered at run time (DejaVu Sans from Debian's fonts-dejavu-core);
//! without one, plots are drawn without text.

use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const CANDIDATES: [&str; 2] =
    ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"];

/// Registers the font once; true when plots can draw text.
pub fn font_available() -> bool {
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        for path in CANDIDATES {
            if let Ok(bytes) = std::fs::read(path) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

/// Line colours, told apart at a glance (Tableau 20's strong and light tones, in an order
/// that keeps neighbouring series apart); further series reuse them.
const COLOURS: [RGBColor; 14] = [
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
    RGBColor(0, 0, 0),
    RGBColor(174, 199, 232),
    RGBColor(255, 187, 120),
    RGBColor(152, 223, 138),
];

/// One line of a chart: its legend and its points (x, y), both > 0.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
}

/// Draws `series` as lines on log-log axes into a 900 × 600 PNG at `path`; `markers` adds a
/// dot at every point. Axes span the data with a margin.
pub fn log_log_lines(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
    markers: bool,
) -> Result<(), String> {
    let all = || series.iter().flat_map(|s| s.points.iter().copied()).filter(|p| p.0 > 0.0 && p.1 > 0.0);
    if all().next().is_none() {
        return Ok(());
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in all() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let font = font_available();
    let mut builder = ChartBuilder::on(&root);
    builder.margin(20).x_label_area_size(if font { 50 } else { 10 }).y_label_area_size(if font { 80 } else { 10 });
    if font {
        builder.caption(title, ("sans-serif", 20));
    }
    let mut chart = builder
        .build_cartesian_2d((x0 / 2.0..x1 * 2.0).log_scale(), (y0 / 3.0..y1 * 3.0).log_scale())
        .map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    if font {
        mesh.x_desc(x_desc)
            .y_desc(y_desc)
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"));
    } else {
        mesh.disable_x_axis().disable_y_axis();
    }
    mesh.draw().map_err(|e| err(&e))?;
    for (k, s) in series.iter().enumerate() {
        let c = COLOURS[k % COLOURS.len()].to_rgba();
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect();
        let drawn = chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2))).map_err(|e| err(&e))?;
        if font {
            drawn
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3)));
        }
        if markers {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(|e| err(&e))?;
        }
    }
    if font {
        chart
            .configure_series_labels()
            .position(emptier_upper_corner(all(), (x0, x1), (y0, y1)))
            .background_style(WHITE)
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// The upper corner with fewer points in its quarter of the log-log plot, where the legend
/// covers least.
fn emptier_upper_corner(
    points: impl Iterator<Item = (f64, f64)>,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> SeriesLabelPosition {
    let (x_mid, y_mid) = ((x0 * x1).sqrt(), (y0 * y1).sqrt());
    let (mut left, mut right) = (0usize, 0usize);
    for (x, _) in points.filter(|p| p.1 >= y_mid) {
        if x < x_mid {
            left += 1;
        } else {
            right += 1;
        }
    }
    if left <= right { SeriesLabelPosition::UpperLeft } else { SeriesLabelPosition::UpperRight }
}
