//! Embedded font registration. plotters' `ab_glyph` backend has no system
//! font lookup, so text renders only after a font is registered under the
//! family name used by the plots ("sans-serif").

use std::sync::Once;

use plotters::style::{register_font, FontStyle};

/// Family name under which DejaVu Sans is registered.
pub(crate) const FAMILY: &str = "sans-serif";

static REGISTER: Once = Once::new();

/// Registers DejaVu Sans (regular) with plotters exactly once per process.
pub(crate) fn ensure_font() {
    REGISTER.call_once(|| {
        // The bytes are a known-good TTF shipped by the `dejavu` crate, so a
        // failure here is a build/packaging bug, not a runtime condition.
        if register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular()).is_err() {
            panic!("embedded DejaVu Sans font could not be parsed");
        }
    });
}
