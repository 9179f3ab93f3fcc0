//! A top view of a recorded run as a PNG, drawn with `plotters` in the embedded DejaVu
//! font: a title (record, seed, outcome), axes in metres with a metre grid, the final
//! global map (static cells dark, cells the lidar detected red), the static scene, the
//! racks and the unseen pallets and boxes (a body that moved at its start and, after it
//! was set down, at its destination), the reference paths, some controller bands, the
//! driven path coloured by mission leg, the turns in place, start and end; and beside
//! the map a legend with the legs' names and a scale bar.
//!
//! `run.rs` reads the record, `draw.rs` and `legend.rs` draw it. Reads the raw channels
//! of the file; knows the message layouts, not the processes.

mod draw;
mod legend;
pub mod run;

use crate::reader::{ReadError, RecordFile};
use plotters::prelude::*;
use std::path::Path;

pub use legend::Swatch;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Pixels per metre of the map (the picture adds its title, axes and legend).
    pub pixels_per_metre: f64,
    /// Draw every n-th controller band (0 = none).
    pub band_every: usize,
    /// Draw the driven path.
    pub driven: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            pixels_per_metre: 25.0,
            band_every: 15,
            driven: true,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: nothing to draw (no global map, ground truth or robot states recorded)")]
    Empty { path: String },
    #[error("invalid pixels per metre {0}: give a positive number")]
    InvalidScale(f64),
    #[error("a picture of {width} x {height} pixels is empty or larger than 16384 on a side")]
    BadSize { width: f64, height: f64 },
    #[error("drawing failed: {0}")]
    Plot(String),
    #[error("png: {0}")]
    Png(#[from] png::EncodingError),
    #[error("cannot write {path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
}

/// What was drawn.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RenderSummary {
    pub width: u32,
    pub height: u32,
    pub driven_poses: usize,
    pub reference_paths: usize,
    pub bands: usize,
    pub detected_cells: usize,
    /// The mission's legs, by name, in order.
    pub legs: Vec<String>,
    /// The legend's labels, top to bottom.
    pub legend: Vec<String>,
    pub title: String,
    pub truncated: Option<String>,
}

/// Colours of the mission's legs, in order (repeating).
pub const LEG_COLORS: [[u8; 3]; 6] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
];

/// Which layers a picture holds: the playback page draws the moving ones itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Layers {
    pub driven: bool,
    pub bands: bool,
    /// Movable bodies (racks, unseen pallets and boxes).
    pub movables: bool,
}

/// A drawn picture: RGB pixels and the map's world-to-pixel transform.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
    /// Pixel `(px, py)` of the world point `(x, y)` is
    /// `(t[0] + (x - t[2]) * t[4], t[1] + (y - t[3]) * t[5])`.
    pub transform: [f64; 6],
}

impl Picture {
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        let t = &self.transform;
        (t[0] + (x - t[2]) * t[4], t[1] + (y - t[3]) * t[5])
    }

    /// The colour at a pixel, if inside.
    pub fn get(&self, px: u32, py: u32) -> Option<[u8; 3]> {
        if px >= self.width || py >= self.height {
            return None;
        }
        let i = (py as usize * self.width as usize + px as usize) * 3;
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header()?;
            w.write_image_data(&self.rgb)?;
            w.finish()?;
        }
        Ok(out)
    }
}

/// Draws a recorded file.
pub fn render_file(
    file: &RecordFile,
    opts: &RenderOptions,
) -> Result<(Picture, RenderSummary), RenderError> {
    let layers = Layers {
        driven: opts.driven,
        bands: opts.band_every > 0,
        movables: true,
    };
    render_layers(file, opts, layers).map(|(p, s, _)| (p, s))
}

/// Draws the given layers of a recorded file.
pub(crate) fn render_layers(
    file: &RecordFile,
    opts: &RenderOptions,
    layers: Layers,
) -> Result<(Picture, RenderSummary, run::Run), RenderError> {
    if !(opts.pixels_per_metre.is_finite() && opts.pixels_per_metre > 0.0) {
        return Err(RenderError::InvalidScale(opts.pixels_per_metre));
    }
    let run = run::collect(file, opts);
    let extent = draw::extent(&run).ok_or_else(|| RenderError::Empty {
        path: file.path().display().to_string(),
    })?;
    let name = file
        .path()
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let layout = draw::Layout::new(extent, opts.pixels_per_metre)?;
    let (width, height) = (layout.width, layout.height);
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    crate::fonts::ensure();
    let title = draw::title(&run, &name);
    let entries = legend::legend_entries(&run, layers);
    let transform = {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        let t = draw::draw(&root, &layout, &run, layers, &title, &entries)
            .map_err(|e| RenderError::Plot(e.to_string()))?;
        root.present()
            .map_err(|e| RenderError::Plot(e.to_string()))?;
        t
    };
    let detected_cells = run.map.as_ref().map_or(0, |g| {
        g.cells[..g.width as usize * g.height as usize]
            .iter()
            .filter(|&&v| v == 2)
            .count()
    });
    let summary = RenderSummary {
        width,
        height,
        driven_poses: run.driven.len(),
        reference_paths: run.references.len(),
        bands: run.bands.len(),
        detected_cells,
        legs: run.legs.clone(),
        legend: entries.into_iter().map(|e| e.1).collect(),
        title: title.join("\n"),
        truncated: run.truncated.clone(),
    };
    let picture = Picture {
        width,
        height,
        rgb,
        transform,
    };
    Ok((picture, summary, run))
}

/// Renders a recorded file to a PNG.
pub fn render(
    path: &Path,
    out_png: &Path,
    opts: &RenderOptions,
) -> Result<RenderSummary, RenderError> {
    let file = RecordFile::open(path)?;
    let (picture, summary) = render_file(&file, opts)?;
    write_output(out_png, &picture.png()?)?;
    Ok(summary)
}

/// Writes a picture or page to `path`, naming it in the error.
pub(crate) fn write_output(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    std::fs::write(path, bytes).map_err(|source| RenderError::Write {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
pub(crate) mod tests;
