//! The profile's plot (SVG, drawn with `plotters`): one panel per group of series
//! against the tick, each series with its p99 and, dashed, its budget in the legend.
//! Knows the report's series and budgets; not how they were measured.

use super::{ProfileError, ProfileReport};
use crate::fonts::FAMILY;
use crate::latency::{Budgets, nearest_rank};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// The panels, in order: a title and the series it holds (by name, or by prefix when
/// the name ends with a space).
const GROUPS: [(&str, &[&str]); 4] = [
    (
        "compute per tick",
        &["simulator", "lidar", "mapper", "supervisor"],
    ),
    (
        "controller compute and end to end (tick start -> trajectory)",
        &["teb_controller", "end_to_end"],
    ),
    ("global planner, per request", &["global_planner"]),
    (
        "output latency (tick start -> published), not scored",
        &["latency "],
    ),
];

const LATENESS_TITLE: &str = "tick release lateness against start + k*dt (realtime), not scored";

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

const WIDTH: u32 = 1100;
const PANEL_HEIGHT: u32 = 300;

/// One series of a panel: name, samples `(tick, ns)`, budget in ms.
type Line = (String, Vec<(u64, u64)>, Option<f64>);

/// The series of `r` grouped into panels (empty groups left out).
fn panels(r: &ProfileReport) -> Vec<(String, Vec<Line>)> {
    let mut all: Vec<Line> = r
        .book
        .series()
        .into_iter()
        .map(|(name, v)| {
            let budget = r.budgets.as_ref().and_then(|b: &Budgets| b.of(name));
            (name.to_string(), v, budget)
        })
        .collect();
    let mut out = Vec::new();
    for (title, members) in GROUPS {
        let belongs = |n: &str| {
            members.iter().any(|m| {
                if m.ends_with(' ') {
                    n.starts_with(m)
                } else {
                    n == *m
                }
            })
        };
        let (mine, rest): (Vec<Line>, Vec<Line>) = all.into_iter().partition(|l| belongs(&l.0));
        all = rest;
        if !mine.is_empty() {
            out.push((title.to_string(), mine));
        }
    }
    if !all.is_empty() {
        out.push(("other".to_string(), all));
    }
    let late = r.book.release_lateness();
    if !late.is_empty() {
        let line = ("lateness".to_string(), late, None);
        out.push((LATENESS_TITLE.to_string(), vec![line]));
    }
    out
}

/// The plot as an SVG document.
pub fn plot(r: &ProfileReport) -> Result<String, ProfileError> {
    let panels = panels(r);
    let max_tick = panels
        .iter()
        .flat_map(|p| p.1.iter())
        .flat_map(|l| l.1.iter().map(|s| s.0))
        .max()
        .unwrap_or(0)
        .max(1);
    let dt_ms = r.book.dt_ns() as f64 / 1e6;
    // Plotters lays text out with the embedded font's metrics (the SVG names the family).
    crate::fonts::ensure();
    let mut out = String::new();
    {
        let height = PANEL_HEIGHT * panels.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut out, (WIDTH, height)).into_drawing_area();
        let drawn = root.fill(&WHITE).and_then(|()| {
            let areas = root.split_evenly((panels.len().max(1), 1));
            for (area, (title, lines)) in areas.iter().zip(&panels) {
                draw_panel(area, title, lines, max_tick, dt_ms)?;
            }
            root.present()
        });
        drawn.map_err(|e| ProfileError::Plot(e.to_string()))?;
    }
    Ok(out)
}

/// One panel: its series against the tick, budgets dashed, the legend top right.
fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    lines: &[Line],
    max_tick: u64,
    dt_ms: f64,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    let highest = lines
        .iter()
        .flat_map(|l| l.1.iter().map(|s| s.1 as f64 / 1e6).chain(l.2))
        .fold(0.0, f64::max)
        .max(0.01);
    // Room above the data for the legend (about 16 px a line of some 230 px).
    let entries = lines
        .iter()
        .map(|l| 1 + usize::from(l.2.is_some()))
        .sum::<usize>();
    let legend = (entries as f64 * 16.0 + 12.0) / 230.0;
    let top = highest / (1.0 - legend.min(0.6));
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FAMILY, 18))
        .margin(8)
        .x_label_area_size(34)
        .y_label_area_size(58)
        .build_cartesian_2d(0..max_tick, 0.0..top)?;
    chart
        .configure_mesh()
        .x_labels(12)
        .y_labels(6)
        .x_desc(format!("tick (dt = {dt_ms} ms)"))
        .y_desc("ms")
        .label_style((FAMILY, 14))
        .draw()?;
    for (i, (name, samples, budget)) in lines.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let mut sorted: Vec<u64> = samples.iter().map(|s| s.1).collect();
        sorted.sort_unstable();
        let p99 = nearest_rank(&sorted, 0.99) as f64 / 1e6;
        let points = samples.iter().map(|&(t, v)| (t, v as f64 / 1e6));
        let label = format!("{name} (p99 {p99:.2} ms)");
        let series = if samples.len() < 50 {
            // A few samples (plans) read better as points than as a line.
            chart.draw_series(points.map(|p| Circle::new(p, 3, color.filled())))?
        } else {
            chart.draw_series(LineSeries::new(points, color.stroke_width(1)))?
        };
        series
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2)));
        if let Some(b) = *budget {
            let dashed = DashedLineSeries::new([(0, b), (max_tick, b)], 6, 4, color.into());
            chart
                .draw_series(dashed)?
                .label(format!("budget of {name}: {b} ms"))
                .legend(move |(x, y)| {
                    DashedPathElement::new([(x, y), (x + 18, y)], 4, 3, color.stroke_width(1))
                });
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font((FAMILY, 14))
        .draw()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::{ProfileOptions, profile_file};
    use crate::reader::RecordFile;
    use crate::synthetic::synthetic_run;
    use crate::writer::{RecordWriter, WriterOptions};
    use std::io::Cursor;
    use std::path::Path;

    #[test]
    fn one_panel_per_group_with_labelled_ticks_and_budgets_in_the_legend() {
        let mut w = RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default()).unwrap();
        let budgets = std::fs::read(aisle_config::testing::shipped("budgets.toml")).unwrap();
        w.attach("budgets.toml", "application/toml", &budgets, 0)
            .unwrap();
        for s in synthetic_run(100) {
            w.write_raw(s.service, s.log_time, s.bytes.bytes()).unwrap();
        }
        let bytes = w.finish().unwrap().0.into_inner();
        let file = RecordFile::from_bytes(Path::new("p.mcap"), bytes).unwrap();
        let r = profile_file(&file, &ProfileOptions::default()).unwrap();
        let titles: Vec<String> = panels(&r).into_iter().map(|p| p.0).collect();
        assert_eq!(titles.len(), 3, "{titles:?}");
        assert!(titles[0].starts_with("compute per tick"));
        assert!(titles[2].starts_with("output latency"));
        let svg = plot(&r).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("compute per tick"));
        assert!(svg.contains("lidar (p99 1.90 ms)"), "the p99 in the legend");
        assert!(
            svg.contains("budget of lidar: 10 ms"),
            "the budget in the legend"
        );
        assert!(svg.contains("\n90\n</text>"), "labelled x ticks");
        assert!(svg.contains("tick (dt = 100 ms)"));
    }
}
