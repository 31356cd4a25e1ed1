//! Every figure the crate writes, drawn with `plotters` and written twice,
//! as `NAME.svg` and `NAME.png` side by side.
//!
//! | file | drawn by | content |
//! |---|---|---|
//! | `figure3` | [`figure3`] | hand position and pendulum angle per trial, the demonstration dotted (the paper's Figure 3) |
//! | `learning` | [`learning`] | largest angle per trial, and the plan's inconsistency |
//! | `diagnostics` | [`diagnostics`] | the plan against reality per trial ([`crate::diagnostics`]) |
//! | `variants` | [`variants`] | success rate of every variant, with its successes and runs (C2, C6, beyond) |
//! | `lambda` | [`lambda`] | success rate and median trial of success against $\lambda$ (C3-C5) |
//! | `relevance` | [`relevance`] | mean cross-validated scale of each input by trial, relative to the input's spread, and the share of models that set it to 0 (C7) |
//!
//! The first three belong to a learning run ([`crate::output::run_report::write_run`]),
//! the last three to `swingup experiments` ([`experiment_figures`]).
//!
//! **Text.** The PNG's text is drawn with DejaVu Sans, embedded in the
//! program (`swingup/assets/fonts/`, Bitstream Vera licence), so no system
//! font or C library is needed; the SVG names the generic `sans-serif`
//! family and the viewer picks its own.
//!
//! **Missing data.** Non-finite values are left out of lines and markers,
//! and an axis with no finite value shows `[0, 1]`; a run figure with no
//! trials draws empty panels. An experiment figure whose experiment did
//! not run is [`PlotError::NoData`].

mod axis;
mod experiments;
mod run;

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::{
    BitMapBackend, DrawingArea, DrawingAreaErrorKind, DrawingBackend, IntoDrawingArea, SVGBackend,
};

pub use crate::error::PlotError;
pub use axis::{PALETTE, colour};
pub use experiments::{experiment_figure_stems, experiment_figures, lambda, relevance, variants};
pub use run::{diagnostics, figure3, learning};

/// DejaVu Sans 2.37 (Debian's `fonts-dejavu-core`), for the PNG's text.
const FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// The font family every figure's text uses; [`register_font`] maps it to [`FONT`].
pub(crate) const FAMILY: &str = "sans-serif";

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for PlotError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        PlotError::Draw(e.to_string())
    }
}

/// `Result` with [`PlotError`].
pub type Result<T, E = PlotError> = std::result::Result<T, E>;

/// A figure drawn twice: as SVG text and as a PNG image of the same size.
#[derive(Debug, Clone)]
pub struct Plot {
    /// Width and height in pixels (of the PNG, and of the SVG's view box).
    pub size: (u32, u32),
    /// The SVG document.
    pub svg: String,
    /// The PNG file's bytes (8-bit RGB).
    pub png: Vec<u8>,
}

impl Plot {
    /// Writes `dir/stem.svg` and `dir/stem.png`, each replaced atomically
    /// ([`store::replace_file`]), so that an interrupted run leaves either
    /// the old or the new figure.
    ///
    /// # Errors
    /// [`PlotError::Store`] naming the file that could not be written.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        for (ext, bytes) in [("svg", self.svg.as_bytes()), ("png", self.png.as_slice())] {
            let path = dir.join(format!("{stem}.{ext}"));
            store::replace_file(&path, bytes).map_err(|e| PlotError::Store(Box::new(e)))?;
        }
        Ok(())
    }
}

/// A figure that can draw itself on any `plotters` backend.
pub(crate) trait Figure {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root`, which has [`Figure::size`].
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

/// Makes [`FAMILY`] the embedded DejaVu Sans, once per process.
fn register_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, FONT).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// Draws `figure` as SVG and as PNG.
pub(crate) fn render(figure: &impl Figure) -> Result<Plot> {
    register_font()?;
    let (w, h) = figure.size();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        figure.draw(&root)?;
        root.present()?;
    }
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        figure.draw(&root)?;
        root.present()?;
    }
    let png = encode_png(&rgb, (w, h))?;
    Ok(Plot { size: (w, h), svg, png })
}

/// Encodes 8-bit RGB pixels, row by row, as a PNG file.
fn encode_png(rgb: &[u8], (w, h): (u32, u32)) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // fast compression: the figures are mostly flat colour, which deflates
    // well at any level, and they are written after every trial
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header().map_err(|e| PlotError::Png(e.to_string()))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| PlotError::Png(e.to_string()))?;
    writer.finish().map_err(|e| PlotError::Png(e.to_string()))?;
    Ok(out)
}

#[cfg(test)]
pub(crate) mod testing {
    //! Checks shared by the figures' tests: the SVG's texts and elements,
    //! and the PNG's signature and size.

    use super::Plot;

    /// The text content of every `<text>` element, trimmed, unescaped.
    pub(crate) fn texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|s| s.split_once('>').and_then(|(_, rest)| rest.split_once("</text>")))
            .map(|(t, _)| {
                t.trim()
                    .replace("&lt;", "<")
                    .replace("&gt;", ">")
                    .replace("&quot;", "\"")
                    .replace("&apos;", "'")
                    .replace("&amp;", "&")
            })
            .collect()
    }

    /// The elements `<tag .../>` whose attributes include `attr`.
    pub(crate) fn elements<'a>(svg: &'a str, tag: &str, attr: &str) -> Vec<&'a str> {
        svg.lines()
            .filter(|l| l.starts_with(&format!("<{tag} ")) && l.contains(attr))
            .collect()
    }

    /// The value of attribute `name` in element `el`.
    pub(crate) fn attr(el: &str, name: &str) -> f64 {
        el.split(&format!(" {name}=\""))
            .nth(1)
            .and_then(|s| s.split('"').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::NAN)
    }

    /// Asserts that `plot` is a whole SVG document with `expected` among
    /// its texts, and a PNG of the plot's size.
    pub(crate) fn assert_plot(plot: &Plot, expected: &[&str]) {
        assert!(plot.svg.starts_with("<svg"), "{}", &plot.svg[..80.min(plot.svg.len())]);
        assert!(plot.svg.trim_end().ends_with("</svg>"));
        assert_eq!(plot.svg.matches('<').count(), plot.svg.matches('>').count());
        assert!(!plot.svg.contains("NaN") && !plot.svg.contains("inf"));
        let t = texts(&plot.svg);
        for e in expected {
            assert!(t.iter().any(|x| x == e), "no text {e:?} in {t:?}");
        }
        let png = &plot.png;
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        assert_eq!(&png[12..16], b"IHDR");
        let be = |i: usize| u32::from_be_bytes([png[i], png[i + 1], png[i + 2], png[i + 3]]);
        assert_eq!((be(16), be(20)), plot.size, "PNG size");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Empty;

    impl Figure for Empty {
        fn size(&self) -> (u32, u32) {
            (30, 20)
        }
        fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
            root.fill(&plotters::style::WHITE)?;
            Ok(())
        }
    }

    /// A white figure decodes back to white pixels of the right size.
    #[test]
    fn png_decodes_to_the_drawn_pixels() {
        let plot = render(&Empty).expect("plot");
        testing::assert_plot(&plot, &[]);
        let decoder = png::Decoder::new(std::io::Cursor::new(&plot.png));
        let mut reader = decoder.read_info().expect("header");
        let mut buf = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut buf).expect("frame");
        assert_eq!((info.width, info.height), (30, 20));
        assert!(buf[..info.buffer_size()].iter().all(|&b| b == 255));
    }

    /// Writing puts both files next to each other, and a missing
    /// directory is a typed error naming the file.
    #[test]
    fn write_puts_svg_and_png_side_by_side() {
        let plot = render(&Empty).expect("plot");
        let scratch = store::ScratchDir::new("swingup-plot").expect("scratch dir");
        let dir = scratch.path().to_path_buf();
        plot.write(&dir, "empty").expect("write");
        assert!(dir.join("empty.svg").exists() && dir.join("empty.png").exists());
        let err = plot.write(&dir.join("missing"), "empty").expect_err("no directory");
        assert!(
            matches!(err, PlotError::Store(ref e) if e.to_string().contains("empty.svg")),
            "{err}"
        );
    }
}
