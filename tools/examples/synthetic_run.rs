//! Writes the synthetic test run to an MCAP file, renders it and profiles it, so the
//! outputs can be looked at without running the stack:
//! `cargo run -p aisle-tools --example synthetic_run -- OUT_DIR`.

use aisle_tools::synthetic::write_synthetic;
use aisle_tools::{RenderOptions, WriterOptions, profile, render};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&dir)?;
    let mcap = dir.join("synthetic.mcap");
    write_synthetic(std::fs::File::create(&mcap)?, 120, WriterOptions::default())?;
    let summary = render(&mcap, &dir.join("synthetic.png"), &RenderOptions::default())?;
    println!("render: {summary:?}");
    let report = profile(&mcap)?;
    print!("{}", report.table());
    print!("{}", report.histograms());
    report.write_svg(&dir.join("synthetic.svg"))?;
    println!("wrote {}", dir.display());
    Ok(())
}
