//! Writing a figure to its files. A figure is validated first (by `line` or `map`) and then
//! drawn twice through the same [`Figure::draw`], once on plotters' bitmap backend and once on
//! its SVG backend, so the two files show the same thing.
//!
//! The bitmap is drawn into an RGB buffer and encoded here with the png crate rather than by
//! plotters, whose encoder pulls in the whole image crate (JPEG, BMP and more codecs for one
//! PNG); the encoder settings are the image crate's (adaptive row filters), at the best
//! compression. Paths are `<stem>.png` and `<stem>.svg`, the extension appended to the stem
//! rather than replacing one (`fig.v2` gives `fig.v2.png`).

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::{invalid, PlotError};
use crate::font::ensure_font;

/// Default image size in pixels (width, height) used by [`line_plot`](crate::line_plot) and
/// [`scalar_map`](crate::scalar_map).
pub const DEFAULT_SIZE: (u32, u32) = (1000, 700);

/// Smallest accepted image size in pixels (width, height).
pub const MIN_SIZE: (u32, u32) = (320, 240);

/// An error unless `(w, h)` is at least [`MIN_SIZE`].
pub(crate) fn check_size((w, h): (u32, u32)) -> Result<(), PlotError> {
    if w < MIN_SIZE.0 || h < MIN_SIZE.1 {
        return Err(invalid(format!("image size {w}x{h} is below the minimum {}x{}", MIN_SIZE.0, MIN_SIZE.1)));
    }
    Ok(())
}

/// A validated figure, drawable on any backend.
pub(crate) trait Figure {
    /// Draws the whole figure on `root`; an error is the backend's message.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// `stem` with `ext` appended as an extension.
pub(crate) fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Draws `figure` into `<stem>.png` and, when `svg_too`, `<stem>.svg`; returns the paths
/// written (PNG first). Creates the parent directory if missing.
pub(crate) fn render(
    stem: &Path,
    size: (u32, u32),
    figure: &impl Figure,
    svg_too: bool,
) -> Result<Vec<PathBuf>, PlotError> {
    if stem.file_name().is_none() {
        return Err(invalid(format!("output stem {} has no file name", stem.display())));
    }
    let png = with_ext(stem, "png");
    let svg = with_ext(stem, "svg");
    ensure_font().map_err(|message| PlotError::Backend { path: png.clone(), message })?;
    if let Some(parent) = stem.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent)?;
        }
    }
    let backend_err = |path: &Path| {
        let path = path.to_path_buf();
        move |message: String| PlotError::Backend { path, message }
    };

    {
        // Drawn into an RGB buffer and encoded here (see `write_png`), so plotters does not
        // need its image-crate encoder.
        let mut rgb = vec![0u8; 3 * size.0 as usize * size.1 as usize];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
            figure.draw(&root).map_err(backend_err(&png))?;
            root.present().map_err(|e| e.to_string()).map_err(backend_err(&png))?;
        }
        write_png(&png, size, &rgb).map_err(backend_err(&png))?;
    }
    if !svg_too {
        return Ok(vec![png]);
    }
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        figure.draw(&root).map_err(backend_err(&svg))?;
        root.present().map_err(|e| e.to_string()).map_err(backend_err(&svg))?;
    }
    Ok(vec![png, svg])
}

/// Encodes an 8-bit RGB buffer as a PNG file.
fn write_png(path: &Path, size: (u32, u32), rgb: &[u8]) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Adaptive per-row filtering, as the image crate did: plots are mostly flat colour, where
    // it shrinks the files ~3x against no filtering.
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    encoder.set_compression(png::Compression::Best);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(rgb).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use crate::testutil::{cleanup, sample_map, sample_plot, temp_dir};
    use crate::{line_plot, scalar_map, PlotError};

    #[test]
    fn unwritable_output_is_an_error_not_a_panic() {
        let dir = temp_dir("unwritable");
        std::fs::create_dir_all(&dir).unwrap();
        let blocker = dir.join("file");
        std::fs::write(&blocker, b"x").unwrap();
        // The "parent directory" is a regular file: creating it must fail cleanly.
        let r = line_plot(&sample_plot(), &blocker.join("sub").join("fig"));
        assert!(matches!(r, Err(PlotError::Io(_))), "{r:?}");
        let r = scalar_map(&sample_map(2, 2), &blocker.join("map"));
        assert!(matches!(r, Err(PlotError::Io(_) | PlotError::Backend { .. })), "{r:?}");
        cleanup(&dir);
    }
}
