//! Plots of `formica report`, drawn with plotters to PNG and SVG with an embedded font (no
//! system libraries).

use anyhow::{anyhow, Result};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// The embedded font (DejaVu Sans; licence in `assets/DejaVuSans-LICENSE.txt`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

/// Registers the embedded font; call once before drawing.
pub fn init_font() -> Result<()> {
    plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
        .map_err(|_| anyhow!("the embedded font is invalid"))
}

/// A value with an interval, at one category of one series.
#[derive(Debug, Clone, Copy)]
pub struct Estimate {
    /// The value.
    pub y: f64,
    /// Lower end of the interval.
    pub lo: f64,
    /// Upper end of the interval.
    pub hi: f64,
}

/// Points with intervals over categories, one or more series.
pub struct CategoryPlot {
    /// Title.
    pub title: String,
    /// X axis description.
    pub x_desc: String,
    /// Y axis description.
    pub y_desc: String,
    /// Category labels, in order.
    pub categories: Vec<String>,
    /// Series: name and one optional estimate per category.
    pub series: Vec<(String, Vec<Option<Estimate>>)>,
    /// Y range (`None`: from the data).
    pub y_range: Option<(f64, f64)>,
    /// Join a series' points with a line (numeric categories).
    pub connect: bool,
}

/// Step curves (survival) or polylines.
pub struct LinePlot {
    /// Title.
    pub title: String,
    /// X axis description.
    pub x_desc: String,
    /// Y axis description.
    pub y_desc: String,
    /// Curves: name and points.
    pub curves: Vec<(String, Vec<(f64, f64)>)>,
    /// Draw as steps (hold the value until the next point).
    pub steps: bool,
    /// Y range (`None`: from the data).
    pub y_range: Option<(f64, f64)>,
    /// Same scale on both axes (trajectories).
    pub equal_axes: bool,
    /// Show a legend (curves with an empty name get no entry).
    pub legend: bool,
    /// Palette index of each curve (empty: curve i gets colour i).
    pub colors: Vec<usize>,
}

fn color(i: usize) -> RGBColor {
    const C: [RGBColor; 10] = [
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
    C[i % C.len()]
}

fn pad(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-9 {
        return (lo - 0.5, hi + 0.5);
    }
    let m = 0.05 * (hi - lo);
    (lo - m, hi + m)
}

/// Draws a category plot on any backend.
pub fn draw_category<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &CategoryPlot,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let k = p.categories.len().max(1);
    let (y0, y1) = p.y_range.unwrap_or_else(|| {
        let vals = p
            .series
            .iter()
            .flat_map(|(_, v)| v.iter().flatten())
            .flat_map(|e| [e.lo, e.hi, e.y])
            .filter(|v| v.is_finite());
        let (lo, hi) = vals.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        let (lo, hi) = pad(lo.min(0.0), hi);
        (lo.max(0.0), hi)
    });
    let cats = p.categories.clone();
    let longest = cats.iter().map(|c| c.chars().count()).max().unwrap_or(1);
    // Labels too long to sit side by side are turned upright (see `save_category`).
    let upright = upright_labels(root.dim_in_pixel().0, k, longest);
    let label_area = if upright {
        label_height(longest)
    } else if longest > 12 {
        70
    } else {
        45
    };
    // Bars that go on past the top (an infinite quartile: more than a quarter never ended) end
    // in a triangle, said on the axis.
    let clipped = p
        .series
        .iter()
        .flat_map(|(_, v)| v.iter().flatten())
        .any(|e| e.hi > y1);
    let y_desc = if clipped {
        format!("{} (triangle: goes on past the top)", p.y_desc)
    } else {
        p.y_desc.clone()
    };
    let mut chart = ChartBuilder::on(root)
        .caption(
            &p.title,
            (FAMILY, caption_size(root.dim_in_pixel().0, &p.title)),
        )
        .margin(15)
        .x_label_area_size(label_area)
        .y_label_area_size(65)
        .build_cartesian_2d(-0.5f64..(k as f64 - 0.5), y0..y1)
        .map_err(|e| anyhow!("{e}"))?;
    let fmt = move |x: &f64| {
        let i = x.round();
        if !upright && (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < cats.len() {
            cats[i as usize].clone()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .x_labels(k + 1)
        .x_label_formatter(&fmt)
        .disable_x_mesh()
        .x_desc(if upright { "" } else { p.x_desc.as_str() })
        .y_desc(&y_desc)
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 15))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    if upright {
        // Drawn by hand: the mesh centres each label on its tick, rotated or not.
        let style = TextStyle::from((FAMILY, 13).into_font())
            .transform(FontTransform::Rotate90)
            .pos(Pos::new(HPos::Left, VPos::Top));
        for (i, c) in p.categories.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64, y0));
            root.draw_text(c, &style, (px + 7, py + 8))
                .map_err(|e| anyhow!("{e}"))?;
        }
    }
    let ns = p.series.len().max(1);
    let texts = legend_texts(p.series.iter().map(|(n, _)| n.as_str()));
    let width = 0.5_f64.min(0.15 * ns as f64);
    let mut marks: Vec<(i32, i32)> = Vec::new();
    for (s, (_, ests)) in p.series.iter().enumerate() {
        let c = color(s);
        let off = if ns > 1 {
            -width / 2.0 + width * s as f64 / (ns - 1) as f64
        } else {
            0.0
        };
        let pts: Vec<(f64, Estimate)> = ests
            .iter()
            .enumerate()
            .filter_map(|(i, e)| e.map(|e| (i as f64 + off, e)))
            .collect();
        for (x, e) in &pts {
            let lo = chart.backend_coord(&(*x, e.lo.clamp(y0, y1)));
            let hi = chart.backend_coord(&(*x, e.hi.clamp(y0, y1)));
            sample_segment(lo, hi, &mut marks);
        }
        if p.connect {
            for w in pts.windows(2) {
                let a = chart.backend_coord(&(w[0].0, w[0].1.y));
                let b = chart.backend_coord(&(w[1].0, w[1].1.y));
                sample_segment(a, b, &mut marks);
            }
        }
        chart
            .draw_series(pts.iter().map(|(x, e)| {
                PathElement::new(
                    vec![(*x, e.lo.clamp(y0, y1)), (*x, e.hi.clamp(y0, y1))],
                    c.stroke_width(2),
                )
            }))
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .draw_series(
                pts.iter()
                    .filter(|(_, e)| e.hi > y1)
                    .map(|(x, _)| TriangleMarker::new((*x, y1), 7, c.filled())),
            )
            .map_err(|e| anyhow!("{e}"))?;
        if p.connect && pts.len() > 1 {
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|(x, e)| (*x, e.y)),
                    c.mix(0.4).stroke_width(1),
                ))
                .map_err(|e| anyhow!("{e}"))?;
        }
        let series = chart
            .draw_series(
                pts.iter()
                    .map(|(x, e)| Circle::new((*x, e.y), 5, c.filled())),
            )
            .map_err(|e| anyhow!("{e}"))?;
        if ns > 1 {
            series
                .label(texts[s].as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, c.filled()));
        }
    }
    if ns > 1 {
        let corner = legend_corner(chart.plotting_area().get_pixel_range(), &texts, &marks);
        draw_legend(&mut chart, corner)?;
    }
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Draws a line plot on any backend.
pub fn draw_lines<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, p: &LinePlot) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let all = p.curves.iter().flat_map(|(_, c)| c.iter());
    let (mut x0, mut x1, mut ly0, mut ly1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in all {
        if x.is_finite() && y.is_finite() {
            x0 = x0.min(*x);
            x1 = x1.max(*x);
            ly0 = ly0.min(*y);
            ly1 = ly1.max(*y);
        }
    }
    let (mut x0, mut x1) = pad(x0, x1);
    let (mut y0, mut y1) = p.y_range.unwrap_or_else(|| pad(ly0, ly1));
    if p.equal_axes {
        let (w, h) = root.dim_in_pixel();
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let scale = ((x1 - x0) / f64::from(w.max(1))).max((y1 - y0) / f64::from(h.max(1)));
        x0 = cx - scale * f64::from(w) / 2.0;
        x1 = cx + scale * f64::from(w) / 2.0;
        y0 = cy - scale * f64::from(h) / 2.0;
        y1 = cy + scale * f64::from(h) / 2.0;
    }
    let mut chart = ChartBuilder::on(root)
        .caption(
            &p.title,
            (FAMILY, caption_size(root.dim_in_pixel().0, &p.title)),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc(&p.x_desc)
        .y_desc(&p.y_desc)
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 15))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    let mut marks: Vec<(i32, i32)> = Vec::new();
    let texts = legend_texts(p.curves.iter().map(|(n, _)| n.as_str()));
    for (i, (name, pts)) in p.curves.iter().enumerate() {
        let c = color(p.colors.get(i).copied().unwrap_or(i));
        let mut line: Vec<(f64, f64)> = Vec::with_capacity(pts.len() * 2);
        for (j, &(x, y)) in pts.iter().enumerate() {
            if p.steps && j > 0 {
                line.push((x, line[line.len() - 1].1));
            }
            line.push((x, y));
        }
        if p.legend {
            for w in line.windows(2) {
                let (a, b) = (chart.backend_coord(&w[0]), chart.backend_coord(&w[1]));
                sample_segment(a, b, &mut marks);
            }
        }
        let s = chart
            .draw_series(LineSeries::new(line, c.stroke_width(2)))
            .map_err(|e| anyhow!("{e}"))?;
        if p.legend && !name.is_empty() {
            s.label(texts[i].as_str()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
            });
        }
    }
    if p.legend && !p.curves.is_empty() {
        let labels: Vec<&String> = p
            .curves
            .iter()
            .zip(&texts)
            .filter(|((n, _), _)| !n.is_empty())
            .map(|(_, t)| t)
            .collect();
        let corner = legend_corner(chart.plotting_area().get_pixel_range(), &labels, &marks);
        draw_legend(&mut chart, corner)?;
    }
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Writes `stem.png` and `stem.svg` in `dir` with `draw`.
macro_rules! both {
    ($dir:expr, $stem:expr, $size:expr, $draw:ident, $plot:expr) => {{
        let png = $dir.join(format!("{}.png", $stem));
        let svg = $dir.join(format!("{}.svg", $stem));
        {
            let root = BitMapBackend::new(&png, $size).into_drawing_area();
            $draw(&root, $plot)?;
        }
        {
            let root = SVGBackend::new(&svg, $size).into_drawing_area();
            $draw(&root, $plot)?;
        }
        Ok::<(), anyhow::Error>(())
    }};
}

/// Font size (pixels) of a plot's title: 22, or smaller (down to 12) so that a long title
/// (a study's long name) fits in a picture `width` pixels wide.
fn caption_size(width: u32, title: &str) -> u32 {
    // DejaVu Sans averages about 0.55 em per character.
    let chars = title.chars().count().max(1) as f64;
    let fit = (f64::from(width.saturating_sub(30)) / (0.55 * chars)).floor();
    fit.clamp(12.0, 22.0) as u32
}

/// Where in the plotting area the legend goes: a corner or the middle of a side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Corner {
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
    MiddleRight,
    MiddleLeft,
    UpperMiddle,
    LowerMiddle,
}

/// Adds points every 8 pixels or less along the segment from `a` to `b` (both ends included)
/// to `marks`: what a legend drawn over the segment would hide.
fn sample_segment(a: (i32, i32), b: (i32, i32), marks: &mut Vec<(i32, i32)>) {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let n = (dx.abs().max(dy.abs()) / 8).clamp(1, 1000);
    for k in 0..=n {
        marks.push((a.0 + dx * k / n, a.1 + dy * k / n));
    }
}

/// The place in the plotting area (pixel ranges `area`) where a legend of `labels` covers the
/// fewest of `marks` (pixels of the data drawn): the four corners, then the middles of the four
/// sides, the upper right first among equals. A legend in a fixed corner hid the last
/// category's point whenever it was high.
fn legend_corner(
    area: (std::ops::Range<i32>, std::ops::Range<i32>),
    labels: &[impl AsRef<str>],
    marks: &[(i32, i32)],
) -> Corner {
    // The legend's box as plotters draws it at 13 px (a 30 px swatch, the text, margins), with a
    // few pixels to spare.
    let longest = labels
        .iter()
        .map(|l| l.as_ref().chars().count())
        .max()
        .unwrap_or(0);
    let w = i32::try_from(longest)
        .unwrap_or(i32::MAX / 16)
        .saturating_mul(13)
        / 2
        + 50;
    let h = i32::try_from(labels.len())
        .unwrap_or(i32::MAX / 32)
        .saturating_mul(18)
        + 18;
    let (xs, ys) = area;
    let (xm, ym) = ((xs.start + xs.end - w) / 2, (ys.start + ys.end - h) / 2);
    let places = [
        (Corner::UpperRight, xs.end - w, ys.start),
        (Corner::UpperLeft, xs.start, ys.start),
        (Corner::LowerRight, xs.end - w, ys.end - h),
        (Corner::LowerLeft, xs.start, ys.end - h),
        (Corner::MiddleRight, xs.end - w, ym),
        (Corner::MiddleLeft, xs.start, ym),
        (Corner::UpperMiddle, xm, ys.start),
        (Corner::LowerMiddle, xm, ys.end - h),
    ];
    let covered = |x: i32, y: i32| {
        marks
            .iter()
            .filter(|(px, py)| {
                (x..=x.saturating_add(w)).contains(px) && (y..=y.saturating_add(h)).contains(py)
            })
            .count()
    };
    let mut best = (usize::MAX, Corner::UpperRight);
    for (place, x, y) in places {
        let c = covered(x, y);
        if c < best.0 {
            best = (c, place);
        }
    }
    best.1
}

/// Most characters of a legend entry: a longer one (a long parameter value) is cut, so that the
/// legend stays inside the plot.
const LEGEND_CHARS: usize = 48;

/// The legend entries of `names`, each as [`legend_text`] gives it; where two different names
/// would read alike once cut, each of those is numbered (`2: ...`) so that no two read alike.
fn legend_texts<'a>(names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let names: Vec<&str> = names.collect();
    let cut: Vec<String> = names.iter().map(|n| legend_text(n)).collect();
    let clash =
        |i: usize| (0..cut.len()).any(|j| j != i && cut[j] == cut[i] && names[j] != names[i]);
    (0..cut.len())
        .map(|i| {
            if clash(i) {
                let numbered = format!("{}: {}", i + 1, cut[i]);
                legend_text(&numbered)
            } else {
                cut[i].clone()
            }
        })
        .collect()
}

/// A legend entry: `name` on one line, its middle cut out ("...") where longer than
/// [`LEGEND_CHARS`], keeping both ends (two values may differ at either).
fn legend_text(name: &str) -> String {
    let chars: Vec<char> = name
        .chars()
        .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
        .collect();
    if chars.len() <= LEGEND_CHARS {
        return chars.into_iter().collect();
    }
    let tail = 15;
    let head = LEGEND_CHARS - 3 - tail;
    let (a, b): (String, String) = (
        chars[..head].iter().collect(),
        chars[chars.len() - tail..].iter().collect(),
    );
    format!("{a}...{b}")
}

/// Draws the series labels at `corner`, in the reports' style.
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    corner: Corner,
) -> Result<()> {
    let position = match corner {
        Corner::UpperRight => SeriesLabelPosition::UpperRight,
        Corner::UpperLeft => SeriesLabelPosition::UpperLeft,
        Corner::LowerRight => SeriesLabelPosition::LowerRight,
        Corner::LowerLeft => SeriesLabelPosition::LowerLeft,
        Corner::MiddleRight => SeriesLabelPosition::MiddleRight,
        Corner::MiddleLeft => SeriesLabelPosition::MiddleLeft,
        Corner::UpperMiddle => SeriesLabelPosition::UpperMiddle,
        Corner::LowerMiddle => SeriesLabelPosition::LowerMiddle,
    };
    chart
        .configure_series_labels()
        .label_font((FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Saves a category plot as PNG and SVG.
pub fn save_category(dir: &Path, stem: &str, p: &CategoryPlot) -> Result<()> {
    let longest = p
        .categories
        .iter()
        .map(|c| c.chars().count())
        .max()
        .unwrap_or(1);
    let k = p.categories.len().max(1);
    let w = side_by_side_width(k, longest).clamp(640, 2400);
    let size = if upright_labels(w, k, longest) {
        // Upright labels: narrow columns, and the plot grows down by the longest label.
        let w = (160 + 40 * k as u32).clamp(640, 2400);
        (w, 420 + label_height(longest))
    } else {
        (w, 480)
    };
    both!(dir, stem, size, draw_category, p)
}

/// Whether `k` category labels of up to `longest` characters are too long to sit side by side
/// on a plot `width` pixels wide (they are then drawn upright).
fn upright_labels(width: u32, k: usize, longest: usize) -> bool {
    side_by_side_width(k, longest) > width.max(640)
}

/// Width (pixels) a plot needs for `k` category labels of up to `longest` characters side by
/// side: the axis margins and a column of at least 90 pixels per label.
fn side_by_side_width(k: usize, longest: usize) -> u32 {
    let per = (longest as u32)
        .saturating_mul(8)
        .saturating_add(20)
        .max(90);
    per.saturating_mul(k as u32).saturating_add(160)
}

/// Height (pixels) of the label area that holds upright labels of `longest` characters.
fn label_height(longest: usize) -> u32 {
    (7 * longest as u32 + 20).clamp(45, 600)
}

/// Saves a line plot as PNG and SVG.
pub fn save_lines(dir: &Path, stem: &str, p: &LinePlot) -> Result<()> {
    let size = if p.equal_axes { (900, 640) } else { (800, 520) };
    both!(dir, stem, size, draw_lines, p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot(categories: Vec<String>) -> CategoryPlot {
        let k = categories.len();
        CategoryPlot {
            title: "t".into(),
            x_desc: "label".into(),
            y_desc: "success rate".into(),
            series: vec![(
                "s".into(),
                vec![
                    Some(Estimate {
                        y: 0.5,
                        lo: 0.4,
                        hi: 0.6
                    });
                    k
                ],
            )],
            categories,
            y_range: Some((0.0, 1.0)),
            connect: false,
        }
    }

    #[test]
    fn long_case_labels_are_drawn_upright_and_the_picture_grows_to_hold_them() {
        init_font().unwrap();
        // 29 labels of 40-odd characters do not fit side by side in 2400 pixels.
        assert!(upright_labels(2400, 29, 45));
        assert!(!upright_labels(640, 3, 10));
        assert!(!upright_labels(2400, 5, 30));
        let dir = std::env::temp_dir().join(format!("formica-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Width and height from the PNG header (IHDR).
        let png_size = |stem: &str| {
            let b = std::fs::read(dir.join(format!("{stem}.png"))).unwrap();
            let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
            (be(16), be(20))
        };
        let cats: Vec<String> = (0..29)
            .map(|i| format!("case {i}: a label as long as a study's case labels are"))
            .collect();
        save_category(&dir, "long", &plot(cats)).unwrap();
        let svg = std::fs::read_to_string(dir.join("long.svg")).unwrap();
        assert!(svg.contains("rotate(90"), "labels are not upright");
        assert!(
            svg.contains(">\ncase 28: a label as long"),
            "a label is missing"
        );
        let (w, h) = png_size("long");
        assert!(w <= 2400 && h > 480, "{w} x {h}");
        save_category(&dir, "short", &plot(vec!["5".into(), "10".into()])).unwrap();
        let svg = std::fs::read_to_string(dir.join("short.svg")).unwrap();
        assert!(!svg.contains("rotate(90"));
        assert_eq!(png_size("short"), (640, 480));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_bar_past_the_top_ends_in_a_triangle_the_axis_explains() {
        init_font().unwrap();
        let dir = std::env::temp_dir().join(format!("formica-clip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut p = plot(vec!["5".into(), "10".into()]);
        p.y_range = None;
        p.y_desc = "median completion time (s)".into();
        p.series[0].1[1] = Some(Estimate {
            y: 80.0,
            lo: 60.0,
            hi: f64::INFINITY,
        });
        save_category(&dir, "clipped", &p).unwrap();
        let svg = std::fs::read_to_string(dir.join("clipped.svg")).unwrap();
        assert!(svg.contains("(triangle: goes on past the top)"), "{svg}");
        let polygons = svg.matches("<polygon").count();
        p.series[0].1[1] = Some(Estimate {
            y: 80.0,
            lo: 60.0,
            hi: 90.0,
        });
        save_category(&dir, "whole", &p).unwrap();
        let svg = std::fs::read_to_string(dir.join("whole.svg")).unwrap();
        assert!(!svg.contains("triangle"));
        assert_eq!(polygons, svg.matches("<polygon").count() + 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_long_legend_entry_keeps_both_ends_within_its_width() {
        assert_eq!(legend_text("friction 0.5"), "friction 0.5");
        assert_eq!(legend_text("a\nb"), "a b");
        let long = format!("{} alpha", "x".repeat(300));
        let cut = legend_text(&long);
        assert_eq!(cut.chars().count(), LEGEND_CHARS);
        assert!(cut.starts_with("xxx") && cut.ends_with(" alpha") && cut.contains("..."));
        assert_ne!(cut, legend_text(&long.replace("alpha", "beta")));
        // Two that differ only in the middle are numbered apart; the rest are left alone.
        let a = format!("{} 5.0 {}", "x".repeat(40), "y".repeat(40));
        let b = a.replace("5.0", "2.0");
        let texts = legend_texts([a.as_str(), b.as_str(), "short"].into_iter());
        assert_ne!(texts[0], texts[1]);
        assert!(
            texts[0].starts_with("1: ") && texts[1].starts_with("2: "),
            "{texts:?}"
        );
        assert_eq!(texts[2], "short");
        assert!(texts.iter().all(|t| t.chars().count() <= LEGEND_CHARS));
    }

    #[test]
    fn the_legend_goes_to_the_corner_that_hides_the_fewest_points() {
        let area = (0..600, 0..400);
        let labels = ["Chen's rule alone", "occlusion with relays"];
        // Nothing drawn: the upper right, as before.
        assert_eq!(
            legend_corner(area.clone(), &labels, &[]),
            Corner::UpperRight
        );
        // The last category's point high on the plot: not over it.
        let mut marks = Vec::new();
        sample_segment((560, 10), (560, 60), &mut marks);
        assert_eq!(
            legend_corner(area.clone(), &labels, &marks),
            Corner::UpperLeft
        );
        // Both upper corners taken: a lower one, right first.
        sample_segment((20, 10), (20, 60), &mut marks);
        assert_eq!(
            legend_corner(area.clone(), &labels, &marks),
            Corner::LowerRight
        );
        // A bar that crosses the box without an end inside it counts too.
        let mut bar = Vec::new();
        sample_segment((590, -50), (590, 450), &mut bar);
        assert_ne!(legend_corner(area, &labels, &bar), Corner::UpperRight);
    }

    #[test]
    fn a_long_title_gets_a_smaller_font_that_fits() {
        assert_eq!(caption_size(640, "unseen: success rate"), 22);
        let long = "queiroz-macrae-obstacles-n5-15: completion time against swarm size";
        let size = caption_size(640, long);
        assert!((12..22).contains(&size), "{size}");
        assert!(0.55 * f64::from(size) * long.chars().count() as f64 <= 610.0);
        assert_eq!(caption_size(100, &"x".repeat(500)), 12);
    }
}
