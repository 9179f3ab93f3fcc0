//! Draws a [`Run`] with `plotters` on any backend: the title, the map's chart (axes in
//! metres, a metre grid, cells, bodies, paths, turns, start and end) and the legend.
//!
//! Knows the picture's layout and colours; not how a record is read.

use super::legend::{
    BAND, DETECTED, RACK, REFERENCE, STATIC_BODY, STATIC_CELL, Swatch, UNSEEN, draw_legend,
    leg_color,
};
use super::run::{BodyKind, MovableBody, Run};
use super::{Layers, RenderError};
use crate::fonts::FAMILY;
use aisle_geometry::GridView;
use aisle_messages::MissionState;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// Title strip height, margin around the chart, axis label areas, legend strip width.
const TITLE_H: u32 = 58;
const MARGIN: u32 = 12;
const Y_LABEL: u32 = 56;
const X_LABEL: u32 = 46;
const LEGEND_W: u32 = 300;

/// Where the map lies in the picture.
pub(super) struct Layout {
    /// The world rectangle: x0, y0, width, height (metres).
    pub extent: (f64, f64, f64, f64),
    pub ppm: f64,
    plot_w: u32,
    pub width: u32,
    pub height: u32,
}

impl Layout {
    pub fn new(extent: (f64, f64, f64, f64), ppm: f64) -> Result<Self, RenderError> {
        let (pw, ph) = ((extent.2 * ppm).round(), (extent.3 * ppm).round());
        let w = pw + f64::from(MARGIN * 2 + Y_LABEL + LEGEND_W);
        let h = ph + f64::from(TITLE_H + MARGIN * 2 + X_LABEL);
        if !(pw >= 1.0 && ph >= 1.0 && w <= 16384.0 && h <= 16384.0) {
            return Err(RenderError::BadSize {
                width: w,
                height: h,
            });
        }
        Ok(Self {
            extent,
            ppm,
            plot_w: pw as u32,
            width: w as u32,
            height: h as u32,
        })
    }
}

/// The world rectangle to draw: the map, else everything recorded plus a margin.
pub(super) fn extent(run: &Run) -> Option<(f64, f64, f64, f64)> {
    if let Some(g) = run.map_view() {
        return Some((
            g.origin_x,
            g.origin_y,
            g.width as f64 * g.resolution,
            g.height as f64 * g.resolution,
        ));
    }
    let mut pts: Vec<(f64, f64)> = run.driven.iter().map(|p| (p.x, p.y)).collect();
    pts.extend(run.statics.iter().map(|b| (b[0], b[1])));
    pts.extend(
        run.movables
            .iter()
            .flat_map(|b| b.poses.iter().map(|p| (p.x, p.y))),
    );
    if pts.is_empty() {
        return None;
    }
    let fold = |f: fn(&(f64, f64)) -> f64| {
        pts.iter()
            .map(f)
            .fold((f64::MAX, f64::MIN), |a, v| (a.0.min(v), a.1.max(v)))
    };
    let ((minx, maxx), (miny, maxy)) = (fold(|p| p.0), fold(|p| p.1));
    Some((minx - 2.0, miny - 2.0, maxx - minx + 4.0, maxy - miny + 4.0))
}

/// The title's two lines: the record, seed and outcome; the mission's legs and figures.
pub(super) fn title(run: &Run, record: &str) -> [String; 2] {
    let seed = run.seed.as_deref().unwrap_or("unknown");
    let outcome = match &run.outcome {
        Some((MissionState::Succeeded, _)) => "succeeded".to_string(),
        Some((MissionState::Failed, why)) => format!("FAILED: {why}"),
        _ => {
            let leg = run.driven.last().map_or(0, |d| d.leg + 1);
            format!("incomplete (ended in leg {leg} of {})", run.legs.len())
        }
    };
    let legs = if run.legs.is_empty() {
        "no mission status recorded".to_string()
    } else {
        format!("mission: {}", run.legs.join(" → "))
    };
    [
        format!("{record}  ·  seed {seed}  ·  {outcome}"),
        format!(
            "{legs}  ·  {:.1} m driven in {:.1} s",
            run.distance,
            run.end_time()
        ),
    ]
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;
type DrawResult<T, DB> = Result<T, DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Draws everything; returns the map's world-to-pixel transform (see
/// [`super::Picture::transform`]).
pub(super) fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    layout: &Layout,
    run: &Run,
    layers: Layers,
    title: &[String; 2],
    legend: &[(Swatch, String)],
) -> DrawResult<[f64; 6], DB> {
    root.fill(&WHITE)?;
    let (top, rest) = root.split_vertically(TITLE_H);
    let bold = FontDesc::new(FontFamily::Name(FAMILY), 20.0, FontStyle::Bold);
    top.draw(&Text::new(title[0].as_str(), (MARGIN as i32, 8), bold))?;
    let sub = (FAMILY, 15).into_font().color(&RGBColor(60, 60, 60));
    top.draw(&Text::new(title[1].as_str(), (MARGIN as i32, 34), sub))?;
    let (main, side) = rest.split_horizontally(MARGIN * 2 + Y_LABEL + layout.plot_w);
    let (x0, y0, w, h) = layout.extent;
    let mut chart = ChartBuilder::on(&main)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL)
        .y_label_area_size(Y_LABEL)
        .build_cartesian_2d(x0..x0 + w, y0..y0 + h)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels((w / 5.0).ceil() as usize + 1)
        .y_labels((h / 5.0).ceil() as usize + 1)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .x_desc("x (m)")
        .y_desc("y (m)")
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .draw()?;
    grid(&mut chart, layout.extent)?;
    if let Some(g) = run.map_view() {
        map_cells(&mut chart, &g)?;
    }
    for b in &run.statics {
        chart.draw_series([outline(b[0], b[1], b[2], b[3], b[4], STATIC_BODY, 1)])?;
    }
    if layers.movables {
        for b in &run.movables {
            movable(&mut chart, b)?;
        }
    }
    paths(&mut chart, run, layers)?;
    let p0 = chart.backend_coord(&(x0, y0));
    let p1 = chart.backend_coord(&(x0 + w, y0 + h));
    draw_legend(&side.margin(MARGIN as i32, 0, 0, 0), legend, layout.ppm)?;
    Ok([
        f64::from(p0.0),
        f64::from(p0.1),
        x0,
        y0,
        f64::from(p1.0 - p0.0) / w,
        f64::from(p1.1 - p0.1) / h,
    ])
}

/// Light lines every metre, darker every 5 m.
fn grid<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    (x0, y0, w, h): (f64, f64, f64, f64),
) -> DrawResult<(), DB> {
    let style = |v: f64| {
        let c = if (v / 5.0).fract().abs() < 1e-9 {
            205
        } else {
            232
        };
        RGBColor(c, c, c).stroke_width(1)
    };
    let mut lines = Vec::new();
    for i in (x0.ceil() as i64)..=((x0 + w).floor() as i64) {
        let v = i as f64;
        lines.push(PathElement::new([(v, y0), (v, y0 + h)], style(v)));
    }
    for i in (y0.ceil() as i64)..=((y0 + h).floor() as i64) {
        let v = i as f64;
        lines.push(PathElement::new([(x0, v), (x0 + w, v)], style(v)));
    }
    chart.draw_series(lines)?;
    Ok(())
}

/// Static and detected cells, as one rectangle per run of equal cells in a row.
fn map_cells<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    g: &GridView<'_>,
) -> DrawResult<(), DB> {
    let (w, r) = (g.width, g.resolution);
    let mut rects = Vec::new();
    for row in 0..g.height {
        let cells = &g.cells[row * w..(row + 1) * w];
        let mut col = 0;
        while col < w {
            let v = cells[col];
            let end = col + cells[col..].iter().take_while(|&&c| c == v).count();
            let color = match v {
                1 => Some(STATIC_CELL),
                2 => Some(DETECTED),
                _ => None,
            };
            if let Some(c) = color {
                let x = |k: usize| g.origin_x + k as f64 * r;
                let y = g.origin_y + row as f64 * r;
                rects.push(Rectangle::new([(x(col), y), (x(end), y + r)], c.filled()));
            }
            col = end;
        }
    }
    chart.draw_series(rects)?;
    Ok(())
}

fn corners(x: f64, y: f64, th: f64, l: f64, w: f64) -> Vec<(f64, f64)> {
    let (c, s) = (th.cos(), th.sin());
    [
        (0.5, 0.5),
        (-0.5, 0.5),
        (-0.5, -0.5),
        (0.5, -0.5),
        (0.5, 0.5),
    ]
    .iter()
    .map(|(a, b)| (x + a * l * c - b * w * s, y + a * l * s + b * w * c))
    .collect()
}

fn outline(
    x: f64,
    y: f64,
    th: f64,
    l: f64,
    w: f64,
    color: RGBColor,
    width: u32,
) -> PathElement<(f64, f64)> {
    PathElement::new(corners(x, y, th, l, w), color.stroke_width(width))
}

/// A movable body where it ended (filled), where it stood first when it moved (dashed)
/// and, faintly, where it was while carried; a rack is named, with when it was set down.
fn movable<DB: DrawingBackend>(chart: &mut Chart<'_, DB>, b: &MovableBody) -> DrawResult<(), DB> {
    let color = match b.kind {
        BodyKind::Rack => RACK,
        BodyKind::Unseen => UNSEEN,
    };
    let (Some(first), Some(last)) = (b.poses.first(), b.poses.last()) else {
        return Ok(());
    };
    if b.moved() {
        let pts = corners(first.x, first.y, first.theta, b.length, b.width);
        chart.draw_series([DashedPathElement::new(pts, 5, 4, color.stroke_width(2))])?;
        // Every 3 s while carried: where the body went with the robot.
        let mut next = f64::MIN;
        for p in b.poses.iter().filter(|p| p.carried) {
            if p.t >= next {
                next = p.t + 3.0;
                let c = color.mix(0.35);
                let pts = corners(p.x, p.y, p.theta, b.length, b.width);
                chart.draw_series([PathElement::new(pts, c.stroke_width(1))])?;
            }
        }
    }
    let pts = corners(last.x, last.y, last.theta, b.length, b.width);
    chart.draw_series([Polygon::new(pts.clone(), color.mix(0.45).filled())])?;
    chart.draw_series([PathElement::new(pts, color.stroke_width(2))])?;
    if b.kind == BodyKind::Rack {
        let label = match b.dropped_at() {
            Some(t) => format!("{}, set down at {t:.1} s", b.name),
            None => b.name.clone(),
        };
        let at = (last.x + 0.5 * b.length.max(b.width) + 0.2, last.y + 0.3);
        let font = (FAMILY, 13).into_font().color(&RACK);
        chart.draw_series([Text::new(label, at, font)])?;
    }
    Ok(())
}

/// Reference paths, bands, the driven path by leg, the turns in place, start and end.
fn paths<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    run: &Run,
    layers: Layers,
) -> DrawResult<(), DB> {
    for r in &run.references {
        chart.draw_series(LineSeries::new(
            r.clone(),
            REFERENCE.mix(0.8).stroke_width(2),
        ))?;
    }
    if layers.bands {
        for b in &run.bands {
            chart.draw_series(LineSeries::new(b.clone(), BAND.stroke_width(1)))?;
            chart.draw_series(b.iter().map(|&p| Circle::new(p, 2, BAND.filled())))?;
        }
    }
    if !layers.driven {
        return Ok(());
    }
    // One line per run of poses of the same leg, joined to the previous one.
    let mut start = 0;
    while start < run.driven.len() {
        let leg = run.driven[start].leg;
        let end = start
            + run.driven[start..]
                .iter()
                .take_while(|d| d.leg == leg)
                .count();
        let from = start.saturating_sub(1);
        let pts = run.driven[from..end].iter().map(|d| (d.x, d.y));
        chart.draw_series(LineSeries::new(pts, leg_color(leg).stroke_width(3)))?;
        start = end;
    }
    for t in run.turns.iter().filter(|t| (t.to - t.from).abs() > 0.1) {
        let radius = 0.8;
        let n = 24;
        let at = |k: usize| {
            let a = t.from + (t.to - t.from) * k as f64 / n as f64;
            (t.x + radius * a.cos(), t.y + radius * a.sin())
        };
        let color = leg_color(t.leg);
        chart.draw_series(LineSeries::new((0..=n).map(at), color.stroke_width(3)))?;
        // The arrow at the end points along the direction of the turn.
        let tip = at(n);
        let heading = t.to + std::f64::consts::FRAC_PI_2 * (t.to - t.from).signum();
        let back = |da: f64| {
            let a = heading + std::f64::consts::PI + da;
            (tip.0 + 0.35 * a.cos(), tip.1 + 0.35 * a.sin())
        };
        chart.draw_series([Polygon::new(
            vec![tip, back(0.5), back(-0.5)],
            color.filled(),
        )])?;
    }
    if let (Some(first), Some(last)) = (run.driven.first(), run.driven.last()) {
        chart.draw_series([Circle::new((first.x, first.y), 6, BLACK.filled())])?;
        chart.draw_series([Circle::new((last.x, last.y), 6, BLACK.filled())])?;
        chart.draw_series([Circle::new((last.x, last.y), 3, WHITE.filled())])?;
    }
    Ok(())
}
