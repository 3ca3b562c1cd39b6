//! SVG charts of a comparison (plotters' SVG backend: text as `<text>` elements, no fonts
//! or system libraries needed): bar charts of a value per algorithm, like the thesis's
//! figures 4.3-4.4, and scatter plots of roughness against fidelity with the letters as
//! labels. Charts are drawn into strings; the same comparison gives the same bytes.

use plotters::coord::Shift;
use plotters::prelude::*;

/// Pixel size of the bar charts and the scatter plots.
const BAR_SIZE: (u32, u32) = (760, 460);
const SCATTER_SIZE: (u32, u32) = (900, 600);
/// Point labels: font size, and the estimated width of one character (pixels).
const LABEL_PX: u32 = 14;
const LABEL_CHAR_PX: i32 = 9;
const FONT: &str = "sans-serif";
const BAR: RGBColor = RGBColor(70, 110, 170);
const POINT: RGBColor = RGBColor(190, 70, 50);
const REFERENCE: RGBColor = RGBColor(120, 120, 120);

/// A horizontal line across a chart with its name (`rest head`).
#[derive(Debug, Clone, Copy)]
pub struct Reference<'a> {
    pub name: &'a str,
    pub value: f64,
}

/// How to write the numbers of an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ticks {
    /// Fixed decimals.
    Decimals(usize),
    /// Scientific notation (`2.5e-5`), for small variances.
    Scientific,
}

impl Ticks {
    fn format(self, value: f64) -> String {
        match self {
            Ticks::Decimals(places) => format!("{value:.places$}"),
            Ticks::Scientific if value == 0.0 => "0".into(),
            Ticks::Scientific => format!("{value:.1e}"),
        }
    }
}

/// One bar per `(label, value)`, from zero, in the given order.
pub fn bar_chart(
    title: &str,
    y_label: &str,
    ticks: Ticks,
    bars: &[(&str, f64)],
    reference: Option<Reference<'_>>,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, BAR_SIZE).into_drawing_area();
        draw_bars(&root, title, y_label, ticks, bars, reference).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn draw_bars(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    y_label: &str,
    ticks: Ticks,
    bars: &[(&str, f64)],
    reference: Option<Reference<'_>>,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let top = bars
        .iter()
        .map(|b| b.1)
        .chain(reference.map(|r| r.value))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let top = if top > 0.0 { top * 1.12 } else { 1.0 };
    let count = bars.len().max(1);
    // Integer ranges include their end: 0..count - 1 makes `count` segments.
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 20))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(72)
        .build_cartesian_2d((0..count - 1).into_segmented(), 0.0..top)?;
    let label_of = |v: &SegmentValue<usize>| match v {
        SegmentValue::CenterOf(i) => bars.get(*i).map_or(String::new(), |b| b.0.to_string()),
        _ => String::new(),
    };
    let tick_of = |v: &f64| ticks.format(*v);
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(count.max(1))
        .x_label_formatter(&label_of)
        .y_label_formatter(&tick_of)
        .y_desc(y_label)
        .x_desc("algorithm")
        .axis_desc_style((FONT, 15))
        .label_style((FONT, 13))
        .draw()?;
    chart.draw_series(
        bars.iter()
            .enumerate()
            .filter(|(_, b)| b.1.is_finite())
            .map(|(i, b)| {
                let mut bar = Rectangle::new(
                    [(SegmentValue::Exact(i), 0.0), (SegmentValue::Exact(i + 1), b.1)],
                    BAR.filled(),
                );
                bar.set_margin(0, 0, 5, 5);
                bar
            }),
    )?;
    if let Some(r) = reference {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(SegmentValue::Exact(0), r.value), (SegmentValue::Last, r.value)],
                REFERENCE.stroke_width(2),
            )))?
            .label(format!("{} ({})", r.name, ticks.format(r.value)))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], REFERENCE.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.9))
            .border_style(REFERENCE)
            .label_font((FONT, 13))
            .draw()?;
    }
    Ok(())
}

/// One point per `(label, x, y)`, the label beside it. Both axes span the points with a
/// margin; x starts at zero when every x is positive (errors, distances).
pub fn scatter(
    title: &str,
    x_label: &str,
    y_label: &str,
    ticks: (Ticks, Ticks),
    points: &[(&str, f64, f64)],
    reference: Option<Reference<'_>>,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SCATTER_SIZE).into_drawing_area();
        draw_scatter(&root, title, (x_label, y_label), ticks, points, reference)
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn draw_scatter(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    (x_label, y_label): (&str, &str),
    (x_ticks, y_ticks): (Ticks, Ticks),
    points: &[(&str, f64, f64)],
    reference: Option<Reference<'_>>,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let finite: Vec<&(&str, f64, f64)> = points
        .iter()
        .filter(|p| p.1.is_finite() && p.2.is_finite())
        .collect();
    let (x_min, x_max) = span(finite.iter().map(|p| p.1));
    let ys = finite.iter().map(|p| p.2).chain(reference.map(|r| r.value));
    let (y_min, y_max) = span(ys);
    let x_pad = (x_max - x_min).max(x_max.abs() * 0.05).max(1e-9) * 0.08;
    let y_pad = (y_max - y_min).max(y_max.abs() * 0.05).max(1e-12) * 0.12;
    let x_range = if x_min >= 0.0 { 0.0 } else { x_min - x_pad }..x_max + x_pad;
    let y_range = y_min - y_pad..y_max + y_pad;
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 20))
        .margin(14)
        .x_label_area_size(40)
        .y_label_area_size(72)
        .build_cartesian_2d(x_range, y_range)?;
    let x_tick = |v: &f64| x_ticks.format(*v);
    let y_tick = |v: &f64| y_ticks.format(*v);
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&x_tick)
        .y_label_formatter(&y_tick)
        .axis_desc_style((FONT, 15))
        .label_style((FONT, 13))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    if let Some(r) = reference {
        let (x0, x1) = (chart.x_range().start, chart.x_range().end);
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x0, r.value), (x1, r.value)],
                REFERENCE.stroke_width(2),
            )))?
            .label(format!("{} ({})", r.name, y_ticks.format(r.value)))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], REFERENCE.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.9))
            .border_style(REFERENCE)
            .label_font((FONT, 13))
            .draw()?;
    }
    let pixels: Vec<(i32, i32)> = finite.iter().map(|p| chart.backend_coord(&(p.1, p.2))).collect();
    let labels: Vec<&str> = finite.iter().map(|p| p.0).collect();
    let offsets = place_labels(&pixels, &labels);
    chart.draw_series(finite.iter().zip(offsets).map(|(&&(label, x, y), offset)| {
        EmptyElement::at((x, y))
            + Circle::new((0, 0), 4, POINT.filled())
            + Text::new(label.to_string(), offset, (FONT, LABEL_PX).into_font())
    }))?;
    Ok(())
}

/// A rectangle in pixels: left, top, width, height.
type Rect = (i32, i32, i32, i32);

fn overlap(a: Rect, b: Rect) -> i32 {
    let w = (a.0 + a.2).min(b.0 + b.2) - a.0.max(b.0);
    let h = (a.1 + a.3).min(b.1 + b.3) - a.1.max(b.1);
    w.max(0) * h.max(0)
}

/// Where to put each point's label (offset of its top-left corner from the point, pixels):
/// greedily, in order, the candidate position that overlaps the labels already placed and
/// the points least, preferring up-right on ties. Deterministic.
fn place_labels(points: &[(i32, i32)], labels: &[&str]) -> Vec<(i32, i32)> {
    let height = LABEL_PX as i32;
    let dots: Vec<Rect> = points.iter().map(|&(x, y)| (x - 5, y - 5, 10, 10)).collect();
    let mut placed: Vec<Rect> = Vec::with_capacity(points.len());
    let mut offsets = Vec::with_capacity(points.len());
    for (&(x, y), label) in points.iter().zip(labels) {
        let width = LABEL_CHAR_PX * label.chars().count() as i32;
        let candidates = [
            (6, -height - 2),
            (7, -height / 2),
            (6, 2),
            (-6 - width, -height - 2),
            (-7 - width, -height / 2),
            (-6 - width, 2),
            (-width / 2, -height - 6),
            (-width / 2, 6),
        ];
        let cost = |&(dx, dy): &(i32, i32)| {
            let rect = (x + dx, y + dy, width, height);
            placed.iter().chain(&dots).map(|&r| overlap(rect, r)).sum::<i32>()
        };
        let best = candidates
            .iter()
            .enumerate()
            .min_by_key(|(i, c)| (cost(c), *i))
            .map_or(candidates[0], |(_, c)| *c);
        placed.push((x + best.0, y + best.1, width, height));
        offsets.push(best);
    }
    offsets
}

/// Smallest and largest value; (0, 1) for none.
fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if lo <= hi {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_are_svg_with_their_labels_and_repeat_exactly() {
        let bars = [("A", 0.05), ("B", 0.07), ("T", 0.06)];
        let rest = Some(Reference {
            name: "rest head",
            value: 0.04,
        });
        let svg = bar_chart("mean", "roughness", Ticks::Decimals(3), &bars, rest).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let text = |t: &str| format!(">\n{t}\n</text>");
        assert!(
            svg.contains(&text("T")) && svg.contains(&text("rest head (0.040)")),
            "{svg}"
        );
        assert_eq!(
            svg,
            bar_chart("mean", "roughness", Ticks::Decimals(3), &bars, rest).unwrap()
        );

        let points = [("A", 1.0, 0.05), ("B", 2.5, 0.07), ("N", f64::NAN, 0.1)];
        let ticks = (Ticks::Decimals(1), Ticks::Scientific);
        let svg = scatter("trade-off", "error (mm)", "roughness", ticks, &points, None).unwrap();
        assert!(svg.contains(&text("B")) && !svg.contains(&text("N")));
        assert_eq!(Ticks::Scientific.format(2.5e-5), "2.5e-5");
        // one bar and none still draw
        assert!(bar_chart("one", "y", Ticks::Decimals(1), &[("A", 1.0)], None).is_ok());
        assert!(bar_chart("none", "y", Ticks::Decimals(1), &[], None).is_ok());
    }

    #[test]
    fn labels_of_close_points_do_not_overlap() {
        let points = [(100, 100), (104, 102), (100, 108), (300, 300)];
        let offsets = place_labels(&points, &["A", "B", "C", "D"]);
        // a lone point keeps the first choice, up and to the right
        assert_eq!(offsets[3], (6, -16));
        let rect = |i: usize| (points[i].0 + offsets[i].0, points[i].1 + offsets[i].1, 9, 14);
        for i in 0..3 {
            for j in i + 1..3 {
                assert_eq!(overlap(rect(i), rect(j)), 0, "{i} {j}: {offsets:?}");
            }
        }
    }
}
