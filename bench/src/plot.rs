//! The profiles as figures, drawn with `plotters` and written as
//! `STEM.svg` and `STEM.png`: one step curve per solver, the x axis
//! logarithmic (the performance ratio $\alpha \ge 1$, or the budget
//! $\kappa$ in simplex gradients), the y axis the share of problems.
//!
//! The PNG's text uses DejaVu Sans, embedded from `swingup/assets/fonts/`
//! (Bitstream Vera licence), so no system font is needed.

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::{BenchError, Result};
use crate::profiles::Profile;

/// DejaVu Sans 2.37, the same file `swingup` embeds.
const FONT: &[u8] = include_bytes!("../../swingup/assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";
const SIZE: (u32, u32) = (800, 520);

/// Tableau 10, one colour per solver.
const PALETTE: [(u8, u8, u8); 10] = [
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

/// A profile figure: title, x label, and the curves.
pub struct ProfileFigure<'a> {
    /// The title.
    pub title: String,
    /// The x axis's label.
    pub x_label: &'a str,
    /// The smallest x shown (1 for ratios).
    pub x_min: f64,
    /// The curves.
    pub profiles: &'a [Profile],
}

impl ProfileFigure<'_> {
    fn x_max(&self) -> f64 {
        let top = self
            .profiles
            .iter()
            .flat_map(|p| p.values.last())
            .fold(self.x_min * 10.0, |a, &b| a.max(b));
        top * 2.0
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let err = |e: String| BenchError::Plot {
            figure: self.title.clone(),
            reason: e,
        };
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let x_max = self.x_max();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FAMILY, 20))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d((self.x_min..x_max).log_scale(), 0.0..1.02)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc("share of problems")
            .label_style((FAMILY, 13))
            .light_line_style(RGBColor(0xee, 0xee, 0xee))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for (i, p) in self.profiles.iter().enumerate() {
            let (r, g, b) = PALETTE[i % PALETTE.len()];
            let colour = RGBColor(r, g, b);
            // a step curve: flat until each value, then up
            let mut points = vec![(self.x_min, 0.0)];
            let mut level = 0.0;
            for (x, share) in p.steps() {
                let x = x.max(self.x_min);
                points.push((x, level));
                points.push((x, share));
                level = share;
            }
            points.push((x_max, level));
            chart
                .draw_series(LineSeries::new(points, colour.stroke_width(2)))
                .map_err(|e| err(e.to_string()))?
                .label(format!("{} ({:.0}%)", p.solver, 100.0 * level))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FAMILY, 13))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))
    }

    /// Draws the figure and writes `dir/stem.svg` and `dir/stem.png`.
    ///
    /// # Errors
    /// [`BenchError::Plot`] if drawing fails, [`BenchError::Io`] naming the
    /// file that could not be written.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        static REGISTERED: OnceLock<bool> = OnceLock::new();
        let ok = *REGISTERED.get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
        if !ok {
            return Err(BenchError::Plot {
                figure: stem.into(),
                reason: "the embedded font could not be loaded".into(),
            });
        }
        let (w, h) = SIZE;
        let mut svg = String::new();
        self.draw(&SVGBackend::with_string(&mut svg, SIZE).into_drawing_area())?;
        let mut rgb = vec![255u8; w as usize * h as usize * 3];
        self.draw(&BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area())?;
        let mut png_bytes = Vec::new();
        let png_err = |e: png::EncodingError| BenchError::Plot {
            figure: stem.into(),
            reason: e.to_string(),
        };
        {
            let mut encoder = png::Encoder::new(&mut png_bytes, w, h);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header().map_err(png_err)?;
            writer.write_image_data(&rgb).map_err(png_err)?;
            writer.finish().map_err(png_err)?;
        }
        crate::report::write(&dir.join(format!("{stem}.svg")), &svg)?;
        let png_path = dir.join(format!("{stem}.png"));
        Ok(store::replace_file(&png_path, &png_bytes)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_profile_figure_is_written_as_svg_and_png() {
        let scratch = store::ScratchDir::new("bench-plot").expect("scratch dir");
        let dir = scratch.path();
        let profiles = [
            Profile {
                solver: "a".into(),
                values: vec![1.0, 1.0, 3.0],
                problems: 4,
            },
            Profile {
                solver: "b".into(),
                values: vec![],
                problems: 4,
            },
        ];
        ProfileFigure {
            title: "test".into(),
            x_label: "ratio",
            x_min: 1.0,
            profiles: &profiles,
        }
        .write(dir, "t")
        .expect("written");
        let svg = std::fs::read_to_string(dir.join("t.svg")).expect("svg");
        assert!(svg.contains("a (75%)") && svg.contains("b (0%)"));
        let png = std::fs::read(dir.join("t.png")).expect("png");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    }
}
