//! Output formats, the font, colours, and the atomic rendering of a figure to a file.

use crate::PlotError;
use image::ImageEncoder;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::io::Write;
use std::path::Path;
use std::sync::OnceLock;

/// The image formats [`crate`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A PNG bitmap.
    Png,
    /// An SVG vector image.
    Svg,
}

impl Format {
    /// The format named by a file's extension (`.png` or `.svg`, any case).
    pub fn from_path(path: &Path) -> Result<Self, PlotError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(PlotError::Format(path.to_owned())),
        }
    }
}

/// The font family name every figure uses.
pub(crate) const FONT: &str = "sans-serif";

/// Fonts tried in order after `MOMO_PLOT_FONT`.
const FONT_CANDIDATES: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/usr/share/fonts/noto/NotoSans-Regular.ttf",
    "/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// The largest font file read (64 MiB; DejaVu Sans is 0.7 MB, the largest CJK fonts ~20 MB):
/// `MOMO_PLOT_FONT=/dev/zero` is skipped instead of read until memory runs out.
pub const MAX_FONT_BYTES: u64 = 64 << 20;

/// A font file's bytes, or `None` if it cannot be read or is larger than [`MAX_FONT_BYTES`].
fn read_font(path: &std::path::Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let file = std::fs::File::open(path).ok()?;
    let mut bytes = Vec::new();
    file.take(MAX_FONT_BYTES + 1).read_to_end(&mut bytes).ok()?;
    (bytes.len() as u64 <= MAX_FONT_BYTES).then_some(bytes)
}

/// Whether a font was found (the first call registers it): with `false`, figures are drawn
/// without text. Looks at `MOMO_PLOT_FONT` (a TrueType/OpenType file) first, then at the usual
/// locations of DejaVu Sans, Liberation Sans, FreeSans, Noto Sans and Arial.
pub fn font_available() -> bool {
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        let env = std::env::var_os("MOMO_PLOT_FONT").map(std::path::PathBuf::from);
        let candidates = env
            .into_iter()
            .chain(FONT_CANDIDATES.iter().map(std::path::PathBuf::from));
        for path in candidates {
            let Some(bytes) = read_font(&path) else {
                continue;
            };
            // plotters keeps registered fonts for the life of the process.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_ok() {
                return true;
            }
        }
        false
    })
}

/// A figure: its pixel size and how to draw it on any backend.
pub(crate) trait Figure {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Draws the figure; `text` says whether a font is available.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        text: bool,
    ) -> Result<(), PlotError>;
}

/// Maps any plotters error to [`PlotError::Draw`].
pub(crate) fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Renders a figure to `path` (format from the extension), with text if a font is available.
pub(crate) fn render<F: Figure>(figure: &F, path: &Path) -> Result<(), PlotError> {
    let text = font_available();
    render_with(figure, path, text)
}

/// Renders a figure to `path`, with or without text.
pub(crate) fn render_with<F: Figure>(figure: &F, path: &Path, text: bool) -> Result<(), PlotError> {
    let format = Format::from_path(path)?;
    let (w, h) = figure.size();
    let bytes = match format {
        Format::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                root.fill(&WHITE).map_err(draw_err)?;
                figure.draw(&root, text)?;
                root.present().map_err(draw_err)?;
            }
            svg.into_bytes()
        }
        Format::Png => {
            let mut rgb = vec![0u8; w as usize * h as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
                root.fill(&WHITE).map_err(draw_err)?;
                figure.draw(&root, text)?;
                root.present().map_err(draw_err)?;
            }
            let mut png = Vec::new();
            image::codecs::png::PngEncoder::new(&mut png)
                .write_image(&rgb, w, h, image::ColorType::Rgb8)
                .map_err(draw_err)?;
            png
        }
    };
    let mut file = momo_io::AtomicFile::create(path)?;
    file.writer()
        .write_all(&bytes)
        .map_err(|e| PlotError::Io(momo_io::IoError::io(path, e)))?;
    file.commit()?;
    Ok(())
}

/// Colours of the estimates (the ground truth is black).
const PALETTE: &[RGBColor] = &[
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

/// The colour of estimate `i`.
pub(crate) fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// `(min, max)` of the finite values, widened to a non-empty range and padded by `pad` of the
/// width on both sides; `(0, 1)` if there is none.
pub(crate) fn range(values: impl IntoIterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    if hi - lo <= 1e-9 * lo.abs().max(hi.abs()).max(1.0) {
        let w = lo.abs().max(1.0) * 1e-3;
        lo -= w;
        hi += w;
    }
    let width = hi - lo;
    (lo - pad * width, hi + pad * width)
}
