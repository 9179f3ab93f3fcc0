//! The font every picture is drawn with: DejaVu Sans, embedded in the binary (the
//! `dejavu` crate) and registered with `plotters` once, so text renders the same on any
//! machine, with or without system fonts or fontconfig.
//!
//! Knows font registration only, nothing about what is drawn.

use plotters::style::{FontStyle, register_font};
use std::sync::Once;

/// The family name the pictures ask for.
pub const FAMILY: &str = "sans-serif";

/// Registers the embedded fonts (regular and bold) under [`FAMILY`]; cheap after the
/// first call.
pub fn ensure() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are DejaVu's own TTFs; registration only fails on a malformed font,
        // and then plotters reports the family as unavailable when it lays out text.
        let _ = register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular());
        let _ = register_font(FAMILY, FontStyle::Bold, dejavu::sans::bold());
    });
}
