//! Plain SVG plotting shared by the run report and the experiments'
//! plots: panels with linear or log axes, round ticks, legends. No
//! rasteriser or font is needed to write them; any browser shows them.

use std::fmt::Write as _;

pub(crate) const WIDTH: f64 = 800.0;
pub(crate) const HEIGHT: f64 = 500.0;
pub(crate) const FONT: &str = r#"font-family="DejaVu Sans, Helvetica, Arial, sans-serif""#;
/// Line colours per trial (Tableau 10), reused after ten trials.
pub(crate) const COLOURS: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
];

pub(crate) fn colour(i: usize) -> &'static str {
    COLOURS[i % COLOURS.len()]
}

/// Escapes text for XML content and attribute values.
pub(crate) fn xml(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
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

/// A value range that includes `include` and the finite values, padded a little.
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

/// A plot area on the page and the data ranges it shows.
pub(crate) struct Panel {
    pub(crate) left: f64,
    pub(crate) top: f64,
    pub(crate) width: f64,
    pub(crate) height: f64,
    pub(crate) x: (f64, f64),
    pub(crate) y: (f64, f64),
    pub(crate) log_y: bool,
}

impl Panel {
    pub(crate) fn px(&self, x: f64) -> f64 {
        self.left + (x - self.x.0) / (self.x.1 - self.x.0) * self.width
    }

    pub(crate) fn py(&self, y: f64) -> f64 {
        let (y, lo, hi) = if self.log_y {
            (y.log10(), self.y.0.log10(), self.y.1.log10())
        } else {
            (y, self.y.0, self.y.1)
        };
        self.top + self.height - (y - lo) / (hi - lo) * self.height
    }

    pub(crate) fn bottom(&self) -> f64 {
        self.top + self.height
    }

    /// Frame, grid lines and tick labels (x labels only if `x_labels`).
    pub(crate) fn axes(&self, svg: &mut String, x_ticks: &[f64], x_step: f64, x_labels: bool) {
        self.x_axis(svg, x_ticks, x_step, x_labels);
        self.y_axis(svg);
    }

    /// Frame, vertical grid lines and x tick labels (only if `x_labels`).
    pub(crate) fn x_axis(&self, svg: &mut String, x_ticks: &[f64], x_step: f64, x_labels: bool) {
        let _ = writeln!(
            svg,
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#333" stroke-width="1"/>"##,
            self.left, self.top, self.width, self.height
        );
        for &t in x_ticks {
            let x = self.px(t);
            let _ = writeln!(
                svg,
                r##"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="#ddd" stroke-width="1"/>"##,
                self.top,
                self.bottom()
            );
            if x_labels {
                let _ = writeln!(
                    svg,
                    r#"<text x="{x:.1}" y="{:.1}" text-anchor="middle" font-size="12">{}</text>"#,
                    self.bottom() + 16.0,
                    xml(&tick_label(t, x_step))
                );
            }
        }
    }

    /// Horizontal grid lines and y tick labels.
    pub(crate) fn y_axis(&self, svg: &mut String) {
        let y_ticks: Vec<(f64, String)> = if self.log_y {
            let (a, b) = (self.y.0.log10().ceil() as i32, self.y.1.log10().floor() as i32);
            let every = ((b - a) / 5 + 1).max(1) as usize;
            (a..=b)
                .step_by(every)
                .map(|e| (10f64.powi(e), format!("1e{e}")))
                .collect()
        } else {
            let (ticks, step) = nice_ticks(self.y.0, self.y.1, 5);
            ticks.into_iter().map(|t| (t, tick_label(t, step))).collect()
        };
        for (t, label) in y_ticks {
            let y = self.py(t);
            let _ = writeln!(
                svg,
                r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd" stroke-width="1"/>"##,
                self.left,
                self.left + self.width
            );
            let _ = writeln!(
                svg,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end" font-size="12">{}</text>"#,
                self.left - 6.0,
                y + 4.0,
                xml(&label)
            );
        }
    }

    /// A vertical axis title, rotated, left of the panel.
    pub(crate) fn y_title(&self, svg: &mut String, title: &str) {
        let (x, y) = (self.left - 52.0, self.top + self.height / 2.0);
        let _ = writeln!(
            svg,
            r#"<text x="{x:.1}" y="{y:.1}" text-anchor="middle" font-size="13" transform="rotate(-90 {x:.1} {y:.1})">{}</text>"#,
            xml(title)
        );
    }

    /// A dashed horizontal reference line at `y` with a label at its right end.
    pub(crate) fn reference(&self, svg: &mut String, y: f64, label: &str) {
        if !(y > self.y.0 && y < self.y.1) {
            return;
        }
        let py = self.py(y);
        let _ = writeln!(
            svg,
            r##"<line x1="{:.1}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#555" stroke-width="1" stroke-dasharray="6 4"/>"##,
            self.left,
            self.left + self.width
        );
        let _ = writeln!(
            svg,
            r##"<text x="{:.1}" y="{:.1}" text-anchor="end" font-size="11" fill="#555">{}</text>"##,
            self.left + self.width - 4.0,
            // above the line, or below it if too close to the frame
            if py - self.top < 16.0 { py + 13.0 } else { py - 4.0 },
            xml(label)
        );
    }

    /// The points attribute of a polyline through the finite `(x, y)` (and,
    /// on a log scale, positive `y`).
    pub(crate) fn points(&self, xy: impl Iterator<Item = (f64, f64)>) -> String {
        let mut pts = String::new();
        for (x, y) in xy {
            if x.is_finite() && y.is_finite() && (!self.log_y || y > 0.0) {
                if !pts.is_empty() {
                    pts.push(' ');
                }
                let _ = write!(pts, "{:.1},{:.1}", self.px(x), self.py(y));
            }
        }
        pts
    }
}

pub(crate) fn svg_open(svg: &mut String, title: &str) {
    svg_open_sized(svg, title, WIDTH, HEIGHT);
}

/// Opens an SVG document of `width` x `height` with a white background.
pub(crate) fn svg_open_sized(svg: &mut String, title: &str, width: f64, height: f64) {
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" {FONT}>"#
    );
    let _ = writeln!(svg, "<title>{}</title>", xml(title));
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
}

/// The figure's title, centred on `x` at the top.
pub(crate) fn heading(svg: &mut String, x: f64, text: &str) {
    let _ = writeln!(
        svg,
        r#"<text x="{x:.1}" y="24" text-anchor="middle" font-size="15">{}</text>"#,
        xml(text)
    );
}

/// A legend entry at `(x, y)`: a short line in the series' style and its label.
pub(crate) fn legend_entry(svg: &mut String, x: f64, y: f64, style: &str, label: &str) {
    let _ = writeln!(
        svg,
        r#"<line x1="{x:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" {style}/>"#,
        x + 24.0
    );
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" font-size="12">{}</text>"#,
        x + 30.0,
        y + 4.0,
        xml(label)
    );
}
