//! A top view of a recorded run as a PNG: the final global map (static cells dark, cells
//! the lidar detected red), the static scene and the movable racks from ground truth
//! (unseen obstacles, where they stood at the start and at the end), the reference path
//! of every controller goal, some controller bands, and the driven path coloured by
//! mission segment, with a legend.
//!
//! Reads the raw channels of the file; knows the message layouts, not the processes.

use crate::canvas::{Canvas, CanvasError, Rect, Rgb};
use crate::reader::{ReadError, RecordFile};
use aisle_messages::topics::names as s;
use aisle_messages::{
    BodyTruth, ControllerBand, ControllerGoal, MAX_BODIES, MAX_COMMANDS, MAX_GRID_CELLS,
    MAX_PATH_POSES, MissionStatus, OccupancyGrid, RobotState, WorldTruth,
};
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
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
    #[error(transparent)]
    Canvas(#[from] CanvasError),
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
    pub segments: u32,
    pub truncated: Option<String>,
}

/// Colours of mission segments, in order (repeating).
pub const SEGMENT_COLORS: [Rgb; 6] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
];
/// Width of the legend strip right of the map.
pub const LEGEND_PX: u32 = 16 * 6 * 2 + 24;
const STATIC_CELL: Rgb = [70, 70, 70];
const DETECTED: Rgb = [220, 30, 30];
const STATIC_BODY: Rgb = [150, 150, 150];
const RACK: Rgb = [160, 100, 40];
const REFERENCE: Rgb = [120, 120, 255];
const BAND: Rgb = [40, 170, 60];

#[derive(Default)]
struct Run {
    map: Option<Box<OccupancyGrid>>,
    first_bodies: Vec<BodyTruth>,
    last_bodies: Vec<BodyTruth>,
    references: Vec<(u64, Vec<(f64, f64)>)>,
    bands: Vec<Vec<(f64, f64)>>,
    band_count: usize,
    driven: Vec<(f64, f64, u32)>,
    segment: u32,
    max_segment: u32,
    truncated: Option<String>,
}

fn collect(file: &RecordFile, opts: &RenderOptions) -> Run {
    let mut run = Run::default();
    let truncated = file.for_each_payload(|topic, buf| match topic {
        s::GLOBAL_MAP => {
            if let Some(g) = buf.view::<OccupancyGrid>()
                && (g.width as usize).saturating_mul(g.height as usize) <= MAX_GRID_CELLS
                && g.width > 0
                && g.resolution > 0.0
            {
                let mut copy = crate::aligned::zeroed_box::<OccupancyGrid>();
                *copy = *g;
                run.map = Some(copy);
            }
        }
        s::WORLD_TRUTH => {
            if let Some(w) = buf.view::<WorldTruth>() {
                let n = (w.len as usize).min(MAX_BODIES);
                if run.first_bodies.is_empty() {
                    run.first_bodies = w.bodies[..n].to_vec();
                }
                run.last_bodies = w.bodies[..n].to_vec();
            }
        }
        s::CONTROLLER_GOAL => {
            if let Some(g) = buf.view::<ControllerGoal>() {
                let n = (g.len as usize).min(MAX_PATH_POSES);
                if n > 0 && run.references.last().is_none_or(|r| r.0 != g.goal_id) {
                    let pts = g.reference[..n].iter().map(|p| (p.x, p.y)).collect();
                    run.references.push((g.goal_id, pts));
                }
            }
        }
        s::CONTROLLER_BAND => {
            if let Some(b) = buf.view::<ControllerBand>() {
                let n = (b.len as usize).min(MAX_COMMANDS);
                if opts.band_every > 0 && n > 1 && run.band_count % opts.band_every == 0 {
                    run.bands
                        .push(b.poses[..n].iter().map(|p| (p.x, p.y)).collect());
                }
                run.band_count += 1;
            }
        }
        s::MISSION_STATUS => {
            if let Some(st) = buf.view::<MissionStatus>() {
                run.segment = st.segment;
                run.max_segment = run.max_segment.max(st.segment);
            }
        }
        s::ROBOT_STATE => {
            if let Some(r) = buf.view::<RobotState>()
                && r.pose.x.is_finite()
                && r.pose.y.is_finite()
            {
                run.driven.push((r.pose.x, r.pose.y, run.segment));
            }
        }
        _ => {}
    });
    run.truncated = truncated;
    run
}

/// The world rectangle to draw: the map, else everything recorded plus a margin.
fn extent(run: &Run) -> Option<(f64, f64, f64, f64)> {
    if let Some(g) = &run.map {
        return Some((
            g.origin_x,
            g.origin_y,
            f64::from(g.width) * g.resolution,
            f64::from(g.height) * g.resolution,
        ));
    }
    let mut pts: Vec<(f64, f64)> = run.driven.iter().map(|p| (p.0, p.1)).collect();
    pts.extend(run.last_bodies.iter().map(|b| (b.pose.x, b.pose.y)));
    pts.retain(|p| p.0.is_finite() && p.1.is_finite() && p.0.abs() < 1e5 && p.1.abs() < 1e5);
    if pts.is_empty() {
        return None;
    }
    let (minx, maxx) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.0), a.1.max(p.0)));
    let (miny, maxy) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.1), a.1.max(p.1)));
    Some((minx - 2.0, miny - 2.0, maxx - minx + 4.0, maxy - miny + 4.0))
}

/// Draws a recorded file into a canvas.
pub fn render_file(
    file: &RecordFile,
    opts: &RenderOptions,
) -> Result<(Canvas, RenderSummary), RenderError> {
    if !(opts.pixels_per_metre.is_finite() && opts.pixels_per_metre > 0.0) {
        return Err(RenderError::InvalidScale(opts.pixels_per_metre));
    }
    let run = collect(file, opts);
    let (x0, y0, w, h) = extent(&run).ok_or_else(|| RenderError::Empty {
        path: file.path().display().to_string(),
    })?;
    let ppm = opts.pixels_per_metre;
    // The legend gets a strip of its own right of the map, so it hides nothing.
    let legend_m = f64::from(LEGEND_PX) / ppm;
    let mut c = Canvas::new(x0, y0, w + legend_m, h, ppm, [255, 255, 255])?;
    let mut summary = RenderSummary {
        width: c.width,
        height: c.height,
        truncated: run.truncated.clone(),
        segments: run.max_segment + 1,
        ..RenderSummary::default()
    };

    if let Some(g) = &run.map {
        summary.detected_cells = draw_map(&mut c, g);
    }
    draw_bodies(&mut c, &run);
    summary.reference_paths = run.references.len();
    summary.bands = run.bands.len();
    summary.driven_poses = run.driven.len();
    draw_paths(&mut c, &run, opts.driven);
    legend(&mut c, run.max_segment + 1);
    Ok((c, summary))
}

/// The map's static and detected cells; returns how many cells were detected.
fn draw_map(c: &mut Canvas, g: &OccupancyGrid) -> usize {
    for py in 0..c.height {
        for px in 0..c.width {
            let (x, y) = c.to_world(px, py);
            let col = ((x - g.origin_x) / g.resolution).floor();
            let row = ((y - g.origin_y) / g.resolution).floor();
            if col < 0.0 || row < 0.0 || col >= f64::from(g.width) || row >= f64::from(g.height) {
                continue;
            }
            match g.cells[row as usize * g.width as usize + col as usize] {
                1 => c.set(i64::from(px), i64::from(py), STATIC_CELL),
                2 => c.set(i64::from(px), i64::from(py), DETECTED),
                _ => {}
            }
        }
    }
    g.cells[..g.width as usize * g.height as usize]
        .iter()
        .filter(|&&v| v == 2)
        .count()
}

/// The static scene at the end, and the movable racks at the start and at the end.
fn draw_bodies(c: &mut Canvas, run: &Run) {
    let finite = |b: &BodyTruth| {
        b.pose.x.is_finite()
            && b.pose.y.is_finite()
            && b.size[0].is_finite()
            && b.size[1].is_finite()
            && b.size[0].abs() < 1e4
            && b.size[1].abs() < 1e4
    };
    let rect = |b: &BodyTruth| Rect {
        x: b.pose.x,
        y: b.pose.y,
        theta: b.pose.theta,
        length: b.size[0],
        width: b.size[1],
    };
    for b in run
        .last_bodies
        .iter()
        .filter(|b| b.is_static != 0 && finite(b))
    {
        c.stroke_rect(rect(b), 1.0, STATIC_BODY);
    }
    // Movable racks: where they stood at the start (outline) and at the end (filled).
    for b in run
        .first_bodies
        .iter()
        .filter(|b| b.is_static == 0 && finite(b))
    {
        c.stroke_rect(rect(b), 2.0, RACK);
    }
    for b in run
        .last_bodies
        .iter()
        .filter(|b| b.is_static == 0 && finite(b))
    {
        c.fill_rect(rect(b), RACK, 0.45);
    }
}

/// The reference paths, the sampled bands and (when `driven`) the driven path coloured
/// by segment, with its start and end marked.
fn draw_paths(c: &mut Canvas, run: &Run, driven: bool) {
    for (_, r) in &run.references {
        c.polyline(r, 2.0, REFERENCE, 0.8);
    }
    for b in &run.bands {
        c.polyline(b, 1.5, BAND, 0.7);
        for p in b {
            c.disc(p.0, p.1, 1.5, BAND, 0.9);
        }
    }
    let driven: &[(f64, f64, u32)] = if driven { &run.driven } else { &[] };
    for w in driven.windows(2) {
        let color = SEGMENT_COLORS[w[1].2 as usize % SEGMENT_COLORS.len()];
        c.polyline(&[(w[0].0, w[0].1), (w[1].0, w[1].1)], 3.0, color, 1.0);
    }
    if let (Some(first), Some(last)) = (driven.first(), driven.last()) {
        c.disc(first.0, first.1, 6.0, [0, 0, 0], 1.0);
        c.disc(last.0, last.1, 6.0, [0, 0, 0], 1.0);
        c.disc(last.0, last.1, 3.5, [255, 255, 255], 1.0);
    }
}

fn legend(c: &mut Canvas, segments: u32) {
    let mut items: Vec<(Rgb, String)> = vec![
        (STATIC_CELL, "STATIC MAP".into()),
        (DETECTED, "DETECTED".into()),
        (RACK, "RACKS (UNSEEN)".into()),
        (REFERENCE, "REFERENCE".into()),
        (BAND, "TEB BAND".into()),
    ];
    for k in 0..segments.min(SEGMENT_COLORS.len() as u32) {
        items.push((SEGMENT_COLORS[k as usize], format!("SEGMENT {}", k + 1)));
    }
    let scale = 2;
    let line = 10 * scale;
    let box_w = 16 * 6 * scale + 20;
    let box_h = items.len() as i64 * line + 8;
    if i64::from(c.width) < box_w + 8 || i64::from(c.height) < box_h + 8 {
        return;
    }
    let (x0, y0) = (i64::from(c.width) - box_w, 4);
    for py in y0..y0 + box_h {
        for px in x0..x0 + box_w {
            c.blend(px, py, [255, 255, 255], 0.85);
        }
    }
    for (i, (color, label)) in items.iter().enumerate() {
        let y = y0 + 4 + i as i64 * line;
        for py in y..y + 7 * scale {
            for px in x0 + 4..x0 + 4 + 10 {
                c.set(px, py, *color);
            }
        }
        c.text(x0 + 18, y, label, scale, [0, 0, 0]);
    }
}

/// Renders a recorded file to a PNG.
pub fn render(
    path: &Path,
    out_png: &Path,
    opts: &RenderOptions,
) -> Result<RenderSummary, RenderError> {
    let file = RecordFile::open(path)?;
    let (canvas, summary) = render_file(&file, opts)?;
    let png = canvas.png()?;
    write_output(out_png, &png)?;
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
mod tests {
    use super::*;
    use crate::synthetic::write_synthetic;
    use crate::writer::WriterOptions;
    use std::io::Cursor;

    fn synthetic_file(ticks: u64) -> RecordFile {
        let bytes = write_synthetic(Cursor::new(Vec::new()), ticks, WriterOptions::default())
            .unwrap()
            .into_inner();
        RecordFile::from_bytes(Path::new("r.mcap"), bytes).unwrap()
    }

    #[test]
    fn renders_the_map_extent_at_the_requested_scale() {
        let file = synthetic_file(60);
        let opts = RenderOptions {
            pixels_per_metre: 20.0,
            band_every: 2,
            driven: true,
        };
        let (canvas, summary) = render_file(&file, &opts).unwrap();
        // The synthetic map is 40 x 60 cells of 0.5 m: 20 x 30 m, plus the legend strip.
        assert_eq!((summary.width, summary.height), (400 + LEGEND_PX, 600));
        assert_eq!(summary.detected_cells, 2);
        assert_eq!(summary.reference_paths, 2);
        assert_eq!(summary.segments, 2);
        assert_eq!(summary.driven_poses, 60);
        assert!(summary.bands >= 5);
        // The static row 12 (y = -10 + 6.25 m) is dark; a detected cell is red.
        let (_, py) = canvas.to_px(0.0, -3.75);
        assert_eq!(canvas.get(100, py as u32), Some(STATIC_CELL));
        // Cell (row 24, col 16) is detected; the rack drawn over it tints it.
        let (px, py) = canvas.to_px(-5.0 + 16.0 * 0.5 + 0.1, -10.0 + 24.0 * 0.5 + 0.1);
        let [r, g, b] = canvas.get(px as u32, py as u32).unwrap();
        assert!(r > 150 && g < 100 && b < 100, "{r} {g} {b}");
        // The driven path of segment 1 (along y at x = 3) has segment 1's colour.
        let (px, py) = canvas.to_px(3.0, 2.0);
        assert_eq!(canvas.get(px as u32, py as u32), Some(SEGMENT_COLORS[1]));
        let png = canvas.png().unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(png));
        let reader = decoder.read_info().unwrap();
        assert_eq!(
            (reader.info().width, reader.info().height),
            (400 + LEGEND_PX, 600)
        );
    }

    #[test]
    fn rendering_is_deterministic_and_refuses_bad_scales() {
        let file = synthetic_file(20);
        let a = render_file(&file, &RenderOptions::default()).unwrap().0;
        let b = render_file(&file, &RenderOptions::default()).unwrap().0;
        assert_eq!(a.pixels(), b.pixels());
        for bad in [0.0, -1.0, f64::NAN] {
            let opts = RenderOptions {
                pixels_per_metre: bad,
                band_every: 1,
                ..RenderOptions::default()
            };
            assert!(matches!(
                render_file(&file, &opts),
                Err(RenderError::InvalidScale(_))
            ));
        }
    }
}
