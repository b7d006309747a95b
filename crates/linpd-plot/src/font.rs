//! The one font every text is drawn in. plotters' `ab_glyph` renderer has no system fonts:
//! DejaVu Sans, embedded by the `dejavu` crate, is registered under the family name [`FONT`]
//! once per process, so the figures need neither fontconfig nor freetype and look the same on
//! every machine (which keeps the PNG and SVG files reproducible byte for byte).

use std::sync::OnceLock;

use plotters::style::FontStyle;

/// Font family name under which the embedded DejaVu Sans font is registered.
pub(crate) const FONT: &str = "sans-serif";

/// Registers the embedded DejaVu Sans font once; returns the registration error, if any.
pub(crate) fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
        })
        .clone()
}
