//! The profile's plot: every latency series against the tick, with its budget.

use super::ProfileReport;
use std::fmt::Write as _;

/// A plot of every series against the tick, in milliseconds.
pub fn plot(r: &ProfileReport) -> String {
    let series = r.book.series();
    let (w, h, left, right, top, bottom) = (960.0, 480.0, 70.0, 260.0, 20.0, 40.0);
    let plot_w = w - left - right;
    let plot_h = h - top - bottom;
    let max_tick = series
        .iter()
        .flat_map(|s| s.1.iter().map(|x| x.0))
        .max()
        .unwrap_or(1)
        .max(1) as f64;
    let max_ms = r.table.stages.iter().map(|s| s.max_ms).fold(1.0, f64::max) * 1.05;
    let x = |tick: u64| left + tick as f64 / max_tick * plot_w;
    let y = |v_ms: f64| top + plot_h - v_ms / max_ms * plot_h;
    let colors = [
        "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
        "#bcbd22", "#17becf",
    ];
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(o, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    for (i, (name, samples)) in series.iter().enumerate() {
        let c = colors[i % colors.len()];
        let mut pts = String::new();
        for &(t, v) in samples {
            let _ = write!(pts, "{:.1},{:.1} ", x(t), y(v as f64 / 1e6));
        }
        let _ = writeln!(
            o,
            r#"<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="1"/>"#
        );
        let ly = top + 16.0 * i as f64 + 10.0;
        let _ = writeln!(
            o,
            r#"<text x="{}" y="{ly}" fill="{c}">{}</text>"#,
            w - right + 10.0,
            name.replace('&', "&amp;").replace('<', "&lt;")
        );
    }
    let _ = writeln!(o, "</svg>");
    o
}
