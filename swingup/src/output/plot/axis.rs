//! What the figures share: axes with round (or given) ticks on a linear or
//! log scale, panels placed at fixed pixels, lines and markers that skip
//! non-finite values, dashed reference lines, legends and the palette.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{FAMILY, Result};

/// Line colours per series (Tableau 10, as `(r, g, b)`), reused after ten.
pub const PALETTE: [(u8, u8, u8); 10] = [
    (0x1f, 0x77, 0xb4),
    (0xff, 0x7f, 0x0e),
    (0x2c, 0xa0, 0x2c),
    (0xd6, 0x27, 0x28),
    (0x94, 0x67, 0xbd),
    (0x8c, 0x56, 0x4b),
    (0xe3, 0x77, 0xc2),
    (0x7f, 0x7f, 0x7f),
    (0xbc, 0xbd, 0x22),
    (0x17, 0xbe, 0xcf),
];

/// Series `i`'s colour from [`PALETTE`].
pub fn colour(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// Frame and axis lines.
const FRAME: RGBColor = RGBColor(0x33, 0x33, 0x33);
/// Grid lines.
const GRID: RGBColor = RGBColor(0xdd, 0xdd, 0xdd);
/// Reference lines and notes.
pub(crate) const NOTE: RGBColor = RGBColor(0x55, 0x55, 0x55);

/// Room left of a panel for its tick labels and y title, in pixels.
const Y_LABEL_AREA: i32 = 70;
/// Room below a panel for its tick labels and x title, in pixels.
const X_LABEL_AREA: i32 = 42;

/// The text style of `size` pixels (as the SVG's `font-size`), anchored at `pos`.
pub(crate) fn font(size: f64, h: HPos, v: VPos) -> TextStyle<'static> {
    // plotters writes font-size = size / 1.24 into the SVG
    TextStyle::from((FAMILY, size * 1.24)).pos(Pos::new(h, v))
}

/// Draws `text` on `root` at pixel `(x, y)`.
pub(crate) fn text<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: &str,
    (x, y): (i32, i32),
    style: &TextStyle<'_>,
) -> Result<()> {
    root.draw(&Text::new(text.to_string(), (x, y), style.clone()))?;
    Ok(())
}

/// The figure's title, centred on `x` at the top; also fills the background white.
pub(crate) fn heading<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, x: i32, title: &str) -> Result<()> {
    root.fill(&WHITE)?;
    text(root, title, (x, 24), &font(15.0, HPos::Center, VPos::Bottom))
}

/// A tick label: short, no trailing zeros.
pub(crate) fn tick_label(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    format!("{v:.decimals$}")
}

/// About `target` round tick values (steps of 1, 2 or 5 times a power of
/// ten) covering `[lo, hi]`; returns the ticks and the step.
pub(crate) fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let span = (hi - lo).abs();
    if !(span.is_finite() && span > 0.0) {
        return (vec![lo], 1.0);
    }
    let raw = span / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let ticks = (first..=last).map(|i| i as f64 * step).collect();
    (ticks, step)
}

/// A value range that includes `include` and the finite values, padded a
/// little; `[0, 1]` if there is no finite value.
pub(crate) fn range(values: impl Iterator<Item = f64>, include: &[f64], pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.chain(include.iter().copied()).filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        let d = if lo.abs() > 0.0 { 0.5 * lo.abs() } else { 1.0 };
        return (lo - d, hi + d);
    }
    let p = pad * (hi - lo);
    (lo - p, hi + p)
}

/// One axis of a panel: its range and labelled ticks, in plotted units
/// ($\log_{10}$ of the value on a log scale).
#[derive(Debug, Clone)]
pub(crate) struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
    ticks: Vec<(f64, String)>,
}

impl Axis {
    /// A linear axis over `(lo, hi)` with about `target` round ticks.
    pub(crate) fn linear((lo, hi): (f64, f64), target: usize) -> Self {
        let (ticks, step) = nice_ticks(lo, hi, target);
        let ticks = ticks.into_iter().map(|t| (t, tick_label(t, step))).collect();
        Self::with_ticks((lo, hi), ticks)
    }

    /// A linear axis over `(lo, hi)` with the given ticks (those inside it).
    pub(crate) fn with_ticks((lo, hi): (f64, f64), ticks: Vec<(f64, String)>) -> Self {
        let (lo, hi) = if lo.is_finite() && hi.is_finite() && hi > lo {
            (lo, hi)
        } else {
            (0.0, 1.0)
        };
        let ticks = ticks.into_iter().filter(|(t, _)| *t >= lo && *t <= hi).collect();
        Self {
            lo,
            hi,
            log: false,
            ticks,
        }
    }

    /// A log axis over the positive `(lo, hi)`, ticks `1eN` at (up to
    /// about six) powers of ten.
    pub(crate) fn log((lo, hi): (f64, f64)) -> Self {
        let (lo, hi) = if lo > 0.0 && hi > lo && hi.is_finite() {
            (lo.log10(), hi.log10())
        } else {
            (-1.0, 1.0)
        };
        let (a, b) = (lo.ceil() as i32, hi.floor() as i32);
        let every = ((b - a) / 5 + 1).max(1) as usize;
        let ticks = (a..=b).step_by(every).map(|e| (e as f64, format!("1e{e}"))).collect();
        Self {
            log: true,
            ..Self::with_ticks((lo, hi), ticks)
        }
    }

    /// `v` in plotted units, if it can be plotted (finite, and positive on
    /// a log scale).
    pub(crate) fn map(&self, v: f64) -> Option<f64> {
        let v = if self.log { v.log10() } else { v };
        v.is_finite().then_some(v)
    }

    /// The plotted range.
    pub(crate) fn bounds(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    fn label(&self, v: f64) -> String {
        let tol = 1e-9 * (self.hi - self.lo);
        self.ticks
            .iter()
            .find(|(t, _)| (t - v).abs() <= tol)
            .map_or_else(String::new, |(_, l)| l.clone())
    }
}

/// A linear map onto the pixels with grid lines at the ticks.
impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let t = (v - self.lo) / (self.hi - self.lo);
        if !t.is_finite() {
            return limit.0;
        }
        // saturates far off the panel instead of overflowing
        limit.0 + (f64::from(limit.1 - limit.0) * t).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.iter().map(|t| t.0).collect()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

/// The coordinates of a panel.
pub(crate) type Coord = Cartesian2d<Axis, Axis>;

/// A panel's chart, to draw series on.
pub(crate) type Chart<'a, DB> = ChartContext<'a, DB, Coord>;

/// A plot area at fixed pixels on the figure, with its axes and titles.
#[derive(Debug, Clone)]
pub(crate) struct Panel {
    /// Left, top, width and height of the plot area in pixels.
    pub(crate) rect: (i32, i32, i32, i32),
    pub(crate) x: Axis,
    pub(crate) y: Axis,
    /// Label the x ticks (else the panel below shares them).
    pub(crate) x_labels: bool,
    pub(crate) x_title: Option<String>,
    pub(crate) y_title: Option<String>,
}

impl Panel {
    /// A panel at `rect` with labelled x ticks and no titles.
    pub(crate) fn new(rect: (i32, i32, i32, i32), x: Axis, y: Axis) -> Self {
        Self {
            rect,
            x,
            y,
            x_labels: true,
            x_title: None,
            y_title: None,
        }
    }

    /// Sets the y axis title.
    pub(crate) fn y_title(mut self, title: &str) -> Self {
        self.y_title = Some(title.to_string());
        self
    }

    /// Sets the x axis title.
    pub(crate) fn x_title(mut self, title: &str) -> Self {
        self.x_title = Some(title.to_string());
        self
    }

    /// Leaves the x tick labels out.
    pub(crate) fn no_x_labels(mut self) -> Self {
        self.x_labels = false;
        self
    }

    /// The horizontal centre of the plot area in pixels.
    pub(crate) fn centre(&self) -> i32 {
        self.rect.0 + self.rect.2 / 2
    }

    /// Draws the frame, grid, tick labels and titles; returns the chart.
    pub(crate) fn draw<'a, DB: DrawingBackend>(&self, root: &'a DrawingArea<DB, Shift>) -> Result<Chart<'a, DB>> {
        let (w, h) = root.dim_in_pixel();
        let (left, top, width, height) = self.rect;
        let mut chart = ChartBuilder::on(root)
            .margin_left(left - Y_LABEL_AREA)
            .margin_top(top)
            .margin_right(w as i32 - left - width)
            .margin_bottom(h as i32 - top - height - X_LABEL_AREA)
            .y_label_area_size(Y_LABEL_AREA)
            .x_label_area_size(X_LABEL_AREA)
            .build_cartesian_2d(self.x.clone(), self.y.clone())?;
        let x_label = |v: &f64| {
            if self.x_labels { self.x.label(*v) } else { String::new() }
        };
        let y_label = |v: &f64| self.y.label(*v);
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .axis_style(FRAME)
            .label_style(font(12.0, HPos::Center, VPos::Center))
            .axis_desc_style(font(13.0, HPos::Center, VPos::Center));
        if let Some(t) = &self.x_title {
            mesh.x_desc(t.as_str());
        }
        if let Some(t) = &self.y_title {
            mesh.y_desc(t.as_str());
        }
        mesh.draw()?;
        let (x, y) = (self.x.bounds(), self.y.bounds());
        chart.draw_series(std::iter::once(Rectangle::new([(x.0, y.0), (x.1, y.1)], FRAME)))?;
        Ok(chart)
    }

    /// Maps data points to plotted ones, leaving out those that cannot be plotted.
    pub(crate) fn points(&self, xy: impl IntoIterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
        xy.into_iter()
            .filter_map(|(x, y)| Some((self.x.map(x)?, self.y.map(y)?)))
            .collect()
    }

    /// A line through the plottable points of `xy`.
    pub(crate) fn line<DB: DrawingBackend>(
        &self,
        chart: &mut Chart<'_, DB>,
        xy: impl IntoIterator<Item = (f64, f64)>,
        style: ShapeStyle,
    ) -> Result<()> {
        chart.draw_series(std::iter::once(PathElement::new(self.points(xy), style)))?;
        Ok(())
    }

    /// A dotted line through the plottable points of `xy`.
    pub(crate) fn dotted<DB: DrawingBackend>(
        &self,
        chart: &mut Chart<'_, DB>,
        xy: impl IntoIterator<Item = (f64, f64)>,
        style: ShapeStyle,
    ) -> Result<()> {
        chart.draw_series(std::iter::once(DashedPathElement::new(self.points(xy), 2, 3, style)))?;
        Ok(())
    }

    /// A dashed horizontal reference line at `y` with `label` at its right
    /// end; nothing if `y` is off the panel.
    pub(crate) fn reference<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        chart: &mut Chart<'_, DB>,
        y: f64,
        label: &str,
    ) -> Result<()> {
        let Some(v) = self.y.map(y) else { return Ok(()) };
        let (lo, hi) = self.y.bounds();
        if !(v > lo && v < hi) {
            return Ok(());
        }
        let (x0, x1) = self.x.bounds();
        chart.draw_series(std::iter::once(DashedPathElement::new(
            vec![(x0, v), (x1, v)],
            6,
            4,
            NOTE.stroke_width(1),
        )))?;
        let (px, py) = chart.backend_coord(&(x1, v));
        // above the line, or below it if too close to the frame
        let (ty, vpos) = if py - self.rect.1 < 16 {
            (py + 3, VPos::Top)
        } else {
            (py - 3, VPos::Bottom)
        };
        let style = font(11.0, HPos::Right, vpos).color(&NOTE);
        text(root, label, (px - 4, ty), &style)
    }
}

/// What a legend entry shows beside its label.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Swatch {
    /// A short line.
    Line(RGBColor, u32),
    /// A short dotted line.
    Dotted(RGBColor, u32),
    /// A filled circle.
    Filled(RGBColor),
    /// An open circle.
    Open(RGBColor),
}

/// A legend at pixel `(x, y)`: one entry per row, 18 pixels apart.
pub(crate) fn legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    entries: &[(Swatch, String)],
) -> Result<()> {
    let label = font(12.0, HPos::Left, VPos::Center);
    for (i, (swatch, name)) in entries.iter().enumerate() {
        let y = y + 18 * i as i32;
        match *swatch {
            Swatch::Line(c, w) => root.draw(&PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(w)))?,
            Swatch::Dotted(c, w) => root.draw(&DashedPathElement::new(
                vec![(x, y), (x + 24, y)],
                2,
                3,
                c.stroke_width(w),
            ))?,
            Swatch::Filled(c) => root.draw(&Circle::new((x + 6, y), 5, c.filled()))?,
            Swatch::Open(c) => root.draw(&Circle::new((x + 6, y), 5, c.stroke_width(2)))?,
        }
        text(root, name, (x + 30, y), &label)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ticks are round and inside the range; labels keep the step's decimals.
    #[test]
    fn ticks_are_round() {
        let (t, step) = nice_ticks(0.0, 1.0, 5);
        assert_eq!(step, 0.2);
        assert_eq!(t.len(), 6);
        assert_eq!(tick_label(t[1], step), "0.2");
        let a = Axis::linear((-0.05, 1.05), 5);
        assert_eq!(a.label(1.0), "1.0");
        assert_eq!(a.label(0.3), "");
    }

    /// A log axis plots log10 of the value and labels the decades;
    /// non-positive and non-finite values are not plotted.
    #[test]
    fn log_axis_maps_and_labels_decades() {
        let a = Axis::log((1e-3, 10.0));
        assert_eq!(a.bounds(), (-3.0, 1.0));
        assert_eq!(a.map(100.0), Some(2.0));
        assert_eq!(a.map(0.0), None);
        assert_eq!(a.map(f64::NAN), None);
        assert_eq!(a.label(-3.0), "1e-3");
        assert_eq!(a.label(1.0), "1e1");
        // a bad range falls back instead of failing
        assert_eq!(Axis::log((0.0, f64::NAN)).bounds(), (-1.0, 1.0));
        assert_eq!(Axis::linear((f64::NAN, 1.0), 5).bounds(), (0.0, 1.0));
    }

    /// Ranges ignore non-finite values and fall back to [0, 1] on none.
    #[test]
    fn ranges_skip_non_finite_values() {
        assert_eq!(range([f64::NAN, f64::INFINITY].into_iter(), &[], 0.1), (0.0, 1.0));
        let (lo, hi) = range([1.0, f64::NAN, 3.0].into_iter(), &[], 0.0);
        assert_eq!((lo, hi), (1.0, 3.0));
        assert_eq!(range([2.0].into_iter(), &[], 0.1), (1.0, 3.0));
    }
}
