//! The legend beside the map: what each colour and mark means (the legs by the names
//! the mission gave them), and a scale bar.
//!
//! Knows a [`Run`]'s contents and the colours of the picture; not the map's layout.

use super::run::{BodyKind, Run};
use super::{LEG_COLORS, Layers};
use crate::fonts::FAMILY;
use plotters::coord::Shift;
use plotters::prelude::*;

pub(super) const STATIC_CELL: RGBColor = RGBColor(70, 70, 70);
pub(super) const DETECTED: RGBColor = RGBColor(220, 30, 30);
pub(super) const STATIC_BODY: RGBColor = RGBColor(150, 150, 150);
pub(super) const RACK: RGBColor = RGBColor(140, 80, 30);
pub(super) const UNSEEN: RGBColor = RGBColor(130, 90, 190);
pub(super) const REFERENCE: RGBColor = RGBColor(120, 120, 255);
pub(super) const BAND: RGBColor = RGBColor(40, 170, 60);

/// How a legend entry is marked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Swatch {
    Fill(RGBColor),
    Outline(RGBColor),
    Dashed(RGBColor),
    Line(RGBColor),
    /// A turn in place.
    Arc(RGBColor),
    Start,
    End,
}

pub(super) fn leg_color(leg: usize) -> RGBColor {
    let [r, g, b] = LEG_COLORS[leg % LEG_COLORS.len()];
    RGBColor(r, g, b)
}

/// The legend's entries, top to bottom, for the layers drawn.
pub(crate) fn legend_entries(run: &Run, layers: Layers) -> Vec<(Swatch, String)> {
    let mut out = vec![(Swatch::Fill(STATIC_CELL), "static map".to_string())];
    if run.map_view().is_some_and(|g| g.cells.contains(&2)) {
        out.push((Swatch::Fill(DETECTED), "detected by the lidar".into()));
    }
    if !run.statics.is_empty() {
        out.push((Swatch::Outline(STATIC_BODY), "static scene".into()));
    }
    let has = |k: BodyKind| run.movables.iter().any(|b| b.kind == k);
    if has(BodyKind::Rack) {
        out.push((Swatch::Fill(RACK), "pallet racks".into()));
    }
    if has(BodyKind::Unseen) {
        out.push((Swatch::Fill(UNSEEN), "unseen pallets/boxes".into()));
    }
    if layers.movables && run.movables.iter().any(|b| b.moved()) {
        out.push((Swatch::Dashed(RACK), "moved: where it stood first".into()));
    }
    if !run.references.is_empty() {
        out.push((Swatch::Line(REFERENCE), "reference paths".into()));
    }
    if layers.bands && !run.bands.is_empty() {
        out.push((Swatch::Line(BAND), "TEB bands (sampled)".into()));
    }
    for (i, name) in run.legs.iter().enumerate() {
        let turned = run
            .turns
            .iter()
            .filter(|t| t.leg == i)
            .map(|t| t.to - t.from);
        let turned: f64 = turned.sum();
        let swatch = if layers.driven && turned.abs() > 0.1 {
            Swatch::Arc(leg_color(i))
        } else {
            Swatch::Line(leg_color(i))
        };
        let label = if layers.driven && turned.abs() > 0.1 {
            format!("{}: {name} ({:+.0}° in place)", i + 1, turned.to_degrees())
        } else {
            format!("{}: {name}", i + 1)
        };
        out.push((swatch, label));
    }
    if layers.driven && !run.driven.is_empty() {
        out.push((Swatch::Start, "start".into()));
        out.push((Swatch::End, format!("end, t = {:.1} s", run.end_time())));
    }
    out
}

/// Pixel height of one legend line.
const LINE: i32 = 22;

/// Draws `entries` from the top of `area`, then a scale bar for `ppm` under them.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(Swatch, String)],
    ppm: f64,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = (FAMILY, 14).into_font().color(&BLACK);
    let mut y = 8;
    for (swatch, label) in entries {
        draw_swatch(area, *swatch, (6, y))?;
        area.draw(&Text::new(label.as_str(), (42, y - 1), font.clone()))?;
        y += LINE;
    }
    // The longest round length that fits the strip.
    let (width, _) = area.dim_in_pixel();
    let room = f64::from(width.saturating_sub(60));
    let metres = [50.0, 20.0, 10.0, 5.0, 2.0, 1.0]
        .into_iter()
        .find(|m| m * ppm <= room.min(220.0))
        .unwrap_or(1.0);
    let len = (metres * ppm).round() as i32;
    let y = y + 20;
    area.draw(&Text::new("scale", (6, y - 18), font.clone()))?;
    let bar = BLACK.stroke_width(3);
    area.draw(&PathElement::new([(6, y), (6 + len, y)], bar))?;
    for x in [6, 6 + len] {
        area.draw(&PathElement::new(
            [(x, y - 5), (x, y + 5)],
            BLACK.stroke_width(2),
        ))?;
    }
    let label = format!("{metres} m");
    area.draw(&Text::new(label, (12 + len, y - 8), font.clone()))?;
    area.draw(&Text::new(
        "grid lines every metre",
        (6, y + 12),
        font.color(&RGBColor(90, 90, 90)),
    ))?;
    Ok(())
}

fn draw_swatch<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    swatch: Swatch,
    (x, y): (i32, i32),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (w, h) = (28, 14);
    let mid = y + h / 2;
    match swatch {
        Swatch::Fill(c) => area.draw(&Rectangle::new([(x, y), (x + w, y + h)], c.filled())),
        Swatch::Outline(c) => {
            area.draw(&Rectangle::new([(x, y), (x + w, y + h)], c.stroke_width(2)))
        }
        Swatch::Dashed(c) => {
            let corners = [(x, y), (x + w, y), (x + w, y + h), (x, y + h), (x, y)];
            area.draw(&plotters::element::DashedPathElement::new(
                corners,
                4,
                3,
                c.stroke_width(2),
            ))
        }
        Swatch::Line(c) => area.draw(&PathElement::new(
            [(x, mid), (x + w, mid)],
            c.stroke_width(3),
        )),
        Swatch::Arc(c) => {
            let pts: Vec<(i32, i32)> = (0..=12)
                .map(|k| {
                    let a = std::f64::consts::PI * f64::from(k) / 12.0;
                    (
                        x + w / 2 + (12.0 * a.cos()) as i32,
                        y + h - (12.0 * a.sin()) as i32,
                    )
                })
                .collect();
            area.draw(&PathElement::new(pts, c.stroke_width(3)))?;
            area.draw(&arrow_head(
                (x + 2, y + h),
                -std::f64::consts::FRAC_PI_2,
                7.0,
                c,
            ))
        }
        Swatch::Start => area.draw(&Circle::new((x + w / 2, mid), 6, BLACK.filled())),
        Swatch::End => {
            area.draw(&Circle::new((x + w / 2, mid), 6, BLACK.filled()))?;
            area.draw(&Circle::new((x + w / 2, mid), 3, WHITE.filled()))
        }
    }
}

/// A filled triangle pointing along `heading` (pixel frame, y down) with its tip at `tip`.
pub(super) fn arrow_head(
    tip: (i32, i32),
    heading: f64,
    size: f64,
    color: RGBColor,
) -> Polygon<(i32, i32)> {
    let back = |da: f64| {
        let a = heading + std::f64::consts::PI + da;
        (
            tip.0 + (size * a.cos()).round() as i32,
            tip.1 + (size * a.sin()).round() as i32,
        )
    };
    Polygon::new(vec![tip, back(0.45), back(-0.45)], color.filled())
}
