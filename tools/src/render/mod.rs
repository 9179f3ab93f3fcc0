//! A top view of a recorded run as a PNG (or an SVG), drawn with `plotters` in the embedded DejaVu
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
    #[error("{path}: cannot write {what}; the output must end in {SUPPORTED}")]
    UnsupportedOutput { path: String, what: String },
}

/// The output extensions `render` writes, for messages.
pub const SUPPORTED: &str = ".png (picture), .svg (picture in vectors) or .html (playback page)";

/// What a render writes, decided by the output's extension (case-insensitive); any other
/// extension is refused, so a `run.jpg` never holds PNG bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputFormat {
    Png,
    Svg,
    Html,
}

impl OutputFormat {
    /// The format `out` names, or [`RenderError::UnsupportedOutput`] naming its extension.
    pub fn of(out: &Path) -> Result<OutputFormat, RenderError> {
        let ext = out.extension().map(|e| e.to_string_lossy().to_string());
        match ext.as_deref().map(str::to_ascii_lowercase).as_deref() {
            Some("png") => Ok(OutputFormat::Png),
            Some("svg") => Ok(OutputFormat::Svg),
            Some("html") => Ok(OutputFormat::Html),
            _ => Err(RenderError::UnsupportedOutput {
                path: out.display().to_string(),
                what: match ext {
                    Some(e) => format!("a .{e} file"),
                    None => "a file without an extension".to_string(),
                },
            }),
        }
    }
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

/// A record read and laid out, ready to draw on any backend.
struct Prepared {
    run: run::Run,
    layout: draw::Layout,
    title: [String; 2],
    entries: Vec<(Swatch, String)>,
    layers: Layers,
}

impl Prepared {
    fn new(file: &RecordFile, opts: &RenderOptions, layers: Layers) -> Result<Self, RenderError> {
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
        crate::fonts::ensure();
        Ok(Self {
            layout: draw::Layout::new(extent, opts.pixels_per_metre)?,
            title: draw::title(&run, &name),
            entries: legend::legend_entries(&run, layers),
            run,
            layers,
        })
    }

    /// Draws onto `root`; returns the world-to-pixel transform.
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<[f64; 6], RenderError> {
        let p = &self.run;
        let t = draw::draw(
            root,
            &self.layout,
            p,
            self.layers,
            &self.title,
            &self.entries,
        )
        .map_err(|e| RenderError::Plot(e.to_string()))?;
        root.present()
            .map_err(|e| RenderError::Plot(e.to_string()))?;
        Ok(t)
    }

    fn summary(&self) -> RenderSummary {
        let run = &self.run;
        let detected_cells = run
            .map_view()
            .map_or(0, |g| g.cells.iter().filter(|&&v| v == 2).count());
        RenderSummary {
            width: self.layout.width,
            height: self.layout.height,
            driven_poses: run.driven.len(),
            reference_paths: run.references.len(),
            bands: run.bands.len(),
            detected_cells,
            legs: run.legs.clone(),
            legend: self.entries.iter().map(|e| e.1.clone()).collect(),
            title: self.title.join("\n"),
            truncated: run.truncated.clone(),
        }
    }
}

/// Draws the given layers of a recorded file.
pub(crate) fn render_layers(
    file: &RecordFile,
    opts: &RenderOptions,
    layers: Layers,
) -> Result<(Picture, RenderSummary, run::Run), RenderError> {
    let prepared = Prepared::new(file, opts, layers)?;
    let (width, height) = (prepared.layout.width, prepared.layout.height);
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    let transform = {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        prepared.paint(&root)?
    };
    let summary = prepared.summary();
    let picture = Picture {
        width,
        height,
        rgb,
        transform,
    };
    Ok((picture, summary, prepared.run))
}

/// Draws a recorded file as an SVG document (the same picture, in vectors).
pub fn render_svg(
    file: &RecordFile,
    opts: &RenderOptions,
) -> Result<(String, RenderSummary), RenderError> {
    let layers = Layers {
        driven: opts.driven,
        bands: opts.band_every > 0,
        movables: true,
    };
    let prepared = Prepared::new(file, opts, layers)?;
    let mut svg = String::new();
    {
        let size = (prepared.layout.width, prepared.layout.height);
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        prepared.paint(&root)?;
    }
    Ok((svg, prepared.summary()))
}

/// Renders a recorded file to a PNG (`out` ends in `.png`) or an SVG (`.svg`); any
/// other extension is refused before the record is read (`.html` is
/// [`crate::animate::animate`]'s).
pub fn render(path: &Path, out: &Path, opts: &RenderOptions) -> Result<RenderSummary, RenderError> {
    let format = OutputFormat::of(out)?;
    if format == OutputFormat::Html {
        return Err(RenderError::UnsupportedOutput {
            path: out.display().to_string(),
            what: "a page (.html) here: that is `animate`'s".to_string(),
        });
    }
    let file = RecordFile::open(path)?;
    if format == OutputFormat::Svg {
        let (svg, summary) = render_svg(&file, opts)?;
        write_output(out, svg.as_bytes())?;
        return Ok(summary);
    }
    let (picture, summary) = render_file(&file, opts)?;
    write_output(out, &picture.png()?)?;
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
