//! PNG charts for the benchmark report, drawn with `plotters` (bitmap backend, DejaVu Sans from
//! the system: Debian's `fonts-dejavu-core`, installed by `cargo xtask setup`).

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;

/// Font files tried in order.
const FONTS: [&str; 2] =
    ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/dejavu/DejaVuSans.ttf"];

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("no font for the plots (install fonts-dejavu-core; looked for {0})")]
    NoFont(String),
    #[error("{path}: {message}")]
    Draw { path: std::path::PathBuf, message: String },
}

fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        FONTS.iter().any(|f| {
            std::fs::read(f).is_ok_and(|bytes| {
                // plotters keeps fonts for the life of the program.
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
            })
        })
    });
    if ok { Ok(()) } else { Err(PlotError::NoFont(FONTS.join(", "))) }
}

/// One named series of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// How to draw a chart.
#[derive(Clone, Debug)]
pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    /// Logarithmic axes (values must be positive).
    pub log_x: bool,
    pub log_y: bool,
    /// Join the points of a series with lines.
    pub lines: bool,
}

/// Tableau's ten categorical colours (matplotlib's default cycle).
const COLORS: [RGBColor; 10] = [
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

/// Width of the legend column right of the chart: the legend never covers a point.
const LEGEND_WIDTH: u32 = 330;

/// Size of the chart itself, left of the legend.
const CHART_SIZE: (u32, u32) = (900, 540);

/// Size of every plot image: the chart and the legend column.
pub const IMAGE_SIZE: (u32, u32) = (CHART_SIZE.0 + LEGEND_WIDTH, CHART_SIZE.1);

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else {
        let pad = ((hi - lo) * 0.08).max(hi.abs() * 0.05).max(1e-9);
        ((lo - pad).min(0.0_f64.max(lo - pad)), hi + pad)
    }
}

/// An axis label without trailing zeros: 100000 → "100k", 2.50 → "2.5".
fn compact(v: f64) -> String {
    let trim = |t: String| {
        if t.contains('.') { t.trim_end_matches('0').trim_end_matches('.').to_owned() } else { t }
    };
    if v.abs() >= 10_000.0 && (v / 1000.0).fract().abs() < 1e-9 {
        format!("{}k", trim(format!("{:.0}", v / 1000.0)))
    } else if v.abs() >= 100.0 || v == 0.0 {
        format!("{v:.0}")
    } else {
        // Four significant digits, then trimmed.
        let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
        trim(format!("{v:.digits$}"))
    }
}

/// Ticks of a logarithmic axis over [lo, hi]: labels at 1, 2 and 5 times each power of ten
/// (plotters' own choice crowded the top of a decade with overlapping labels and left decades
/// with none), grid lines at every integer multiple. A range holding fewer than two labels is
/// labelled at its ends.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (mut labels, mut grid) = (Vec::new(), Vec::new());
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return (labels, grid);
    }
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        for m in 1..10 {
            let v = decade * f64::from(m);
            // Within a rounding step of the range (powers of ten are not exact in binary).
            if v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9) {
                grid.push(v);
                if matches!(m, 1 | 2 | 5) {
                    labels.push(v);
                }
            }
        }
        decade *= 10.0;
    }
    if labels.len() < 2 {
        labels = vec![lo, hi];
    }
    (labels, grid)
}

/// A legend entry's lines: names longer than the column holds break at spaces (the column
/// is [`LEGEND_WIDTH`] wide; at 15 px a character is at most about 8.5 px).
fn legend_lines(name: &str) -> Vec<String> {
    const MAX_CHARS: usize = 34;
    let mut lines: Vec<String> = Vec::new();
    for word in name.split(' ') {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= MAX_CHARS => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_owned()),
        }
    }
    lines
}

/// Draws `series` into a PNG at `path` (written atomically): a 900×540 chart with the legend
/// in a column to its right ([`IMAGE_SIZE`] in all).
pub fn draw(path: &Path, chart: &Chart<'_>, series: &[Series]) -> Result<(), PlotError> {
    register_font()?;
    let err = |e: &dyn std::fmt::Display| PlotError::Draw { path: path.to_owned(), message: e.to_string() };
    let (w, h) = IMAGE_SIZE;
    let mut pixels = vec![0u8; (w * h * 3) as usize];
    {
        let canvas = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        canvas.fill(&WHITE).map_err(|e| err(&e))?;
        let (root, legend) = canvas.split_horizontally(CHART_SIZE.0);
        let mut y = 70;
        for (i, s) in series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            legend.draw(&Circle::new((12, y), 6, color.filled())).map_err(|e| err(&e))?;
            for line in legend_lines(&s.name) {
                legend
                    .draw(&Text::new(line, (26, y - 9), ("sans-serif", 15).into_font()))
                    .map_err(|e| err(&e))?;
                y += 19;
            }
            y += 7;
        }
        let xs = range(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)), chart.log_x);
        let ys = range(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)), chart.log_y);
        let log_axis = |(lo, hi): (f64, f64)| {
            let (labels, grid) = log_ticks(lo, hi);
            (lo..hi).log_scale().with_key_points(labels).with_light_points(grid)
        };
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(chart.title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72);
        // The four axis-type combinations are different chart types in plotters.
        macro_rules! plot {
            ($x:expr, $y:expr) => {{
                let mut c = builder.build_cartesian_2d($x, $y).map_err(|e| err(&e))?;
                c.configure_mesh()
                    .x_desc(chart.x_label)
                    .y_desc(chart.y_label)
                    .x_label_formatter(&|v| compact(*v))
                    .y_label_formatter(&|v| compact(*v))
                    .label_style(("sans-serif", 15))
                    .draw()
                    .map_err(|e| err(&e))?;
                for (i, s) in series.iter().enumerate() {
                    let color = COLORS[i % COLORS.len()];
                    let points: Vec<(f64, f64)> =
                        s.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
                    if chart.lines {
                        c.draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
                            .map_err(|e| err(&e))?;
                    }
                    c.draw_series(points.iter().map(|&p| Circle::new(p, 5, color.filled())))
                        .map_err(|e| err(&e))?;
                }
            }};
        }
        match (chart.log_x, chart.log_y) {
            (false, false) => plot!(xs.0..xs.1, ys.0..ys.1),
            (true, false) => plot!(log_axis(xs), ys.0..ys.1),
            (false, true) => plot!(xs.0..xs.1, log_axis(ys)),
            (true, true) => plot!(log_axis(xs), log_axis(ys)),
        }
        root.present().map_err(|e| err(&e))?;
    }
    hairmesh::atomic::write_file_atomic(path, |out| {
        let mut encoder = png::Encoder::new(out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer.write_image_data(&pixels).map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
    .map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_labels_are_compact() {
        assert_eq!(compact(100_000.0), "100k");
        assert_eq!(compact(20_000.0), "20k");
        assert_eq!(compact(1500.0), "1500");
        assert_eq!(compact(120.0), "120");
        assert_eq!(compact(2.5), "2.5");
        assert_eq!(compact(0.001), "0.001");
        assert_eq!(compact(0.0), "0");
    }

    #[test]
    fn log_axes_are_labelled_one_two_five() {
        let (labels, grid) = log_ticks(107.0, 5055.0);
        assert_eq!(labels, vec![200.0, 500.0, 1000.0, 2000.0, 5000.0]);
        assert_eq!(grid.first(), Some(&200.0));
        assert_eq!(grid.len(), 8 + 5);
        // The crowd plot's FLIP axis: every decade gets labels.
        let (labels, _) = log_ticks(0.02, 0.19);
        assert_eq!(labels.len(), 3, "{labels:?}");
        // No 1-2-5 value inside: the ends.
        assert_eq!(log_ticks(1.1, 1.9).0, vec![1.1, 1.9]);
        assert!(log_ticks(0.0, 1.0).0.is_empty());
    }

    #[test]
    fn long_legend_names_wrap_at_spaces() {
        let lines = legend_lines("100 heads × 100000 strands (strand LOD α = 16, vertex α = 256)");
        assert!(lines.len() >= 2 && lines.iter().all(|l| l.chars().count() <= 34), "{lines:?}");
        assert_eq!(lines.join(" "), "100 heads × 100000 strands (strand LOD α = 16, vertex α = 256)");
        assert_eq!(legend_lines("short"), vec!["short".to_owned()]);
    }

    #[test]
    fn a_chart_is_a_png_of_its_size() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("chart.png");
        let series = vec![
            Series { name: "a".into(), points: vec![(1.0, 2.0), (10.0, 20.0), (100.0, f64::NAN)] },
            Series { name: "b".into(), points: vec![(2.0, 1.0), (20.0, 3.0)] },
        ];
        let chart = Chart { title: "t", x_label: "x", y_label: "y", log_x: true, log_y: true, lines: true };
        draw(&path, &chart, &series).expect("draw");
        let image = render::output::read_png(&path).expect("a PNG");
        assert_eq!((image.width, image.height), IMAGE_SIZE);
        // Something besides the white background was drawn.
        assert!(image.pixels.chunks_exact(4).filter(|p| p[0] < 128).count() > 1000);
        // The legend sits in its own column (it used to cover points in the chart's corner):
        // series a's marker is there.
        let a = COLORS[0];
        let in_legend = image
            .pixels
            .chunks_exact(4)
            .enumerate()
            .filter(|(i, p)| *i as u32 % image.width >= CHART_SIZE.0 && p[..3] == [a.0, a.1, a.2])
            .count();
        assert!(in_legend > 20, "{in_legend} legend pixels of series a");
    }
}
