//! Renders and profiles a recorded file, for looking at a run before the CLI has
//! `aisle render` / `aisle profile`:
//! `cargo run -p aisle-tools --release --example look -- RUN.mcap OUT_PREFIX`
//! writes OUT_PREFIX.png and OUT_PREFIX.svg and prints the latency table.

use aisle_tools::{RenderOptions, profile, render};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(a.len() == 2, "usage: look RUN.mcap OUT_PREFIX");
    let input = PathBuf::from(&a[0]);
    let summary = render(
        &input,
        &PathBuf::from(format!("{}.png", a[1])),
        &RenderOptions::default(),
    )?;
    println!("render: {summary:?}");
    let report = profile(&input)?;
    print!("{}", report.table());
    report.write_svg(&PathBuf::from(format!("{}.svg", a[1])))?;
    Ok(())
}
