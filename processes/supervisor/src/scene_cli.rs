//! `aisle scene generate`: a large warehouse scene written as a `warehouse.toml`, from
//! `aisle_config::scene_gen` (which holds the layout; this module only parses flags,
//! checks the result loads and fits the messages, `check::scene_limits`, and writes the
//! file).

use crate::exit;
use aisle_config::scene::Scene;
use aisle_config::scene_gen::{self, GenParams, Layout};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// Subcommands flattened into `aisle`'s own.
#[derive(Debug, Subcommand)]
pub enum SceneCommand {
    /// Warehouse scenes (`warehouse.toml`).
    Scene {
        #[command(subcommand)]
        command: SceneSub,
    },
}

#[derive(Debug, Subcommand)]
pub enum SceneSub {
    /// Write a generated warehouse: rack rows of bays with loads along N picking aisles,
    /// cross aisles, a packaging area with shelves, tables, staging pallets, movable
    /// pallet racks and loose boxes. The same flags give the same file, byte for byte.
    #[command(
        after_help = "Exit: 0 written, 2 could not (a flag out of range, a scene larger than \
the messages and the config reader carry: its size, its movable bodies, its floor in map \
cells; the output not writable)."
    )]
    Generate(GenerateArgs),
}

#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// Picking aisles (1..=500); the width is about 5.2 m per aisle.
    #[arg(long, default_value_t = 19)]
    aisles: u32,
    /// Length of the racked part along the aisles, cross aisles included (metres).
    #[arg(long, default_value_t = 172.0)]
    length: f64,
    /// Seed of the loads' occupancy and the packaging area's contents.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Width of a picking aisle (metres).
    #[arg(long, default_value_t = 3.0)]
    aisle_width: f64,
    /// A cross aisle after at most this much racking (metres).
    #[arg(long, default_value_t = 30.0)]
    cross_every: f64,
    /// Width of a cross aisle (metres).
    #[arg(long, default_value_t = 4.0)]
    cross_width: f64,
    /// Depth of the packaging area at the south end (metres, >= 12).
    #[arg(long, default_value_t = 20.0)]
    packaging_depth: f64,
    /// Chance that a storage slot holds a load (0..=1).
    #[arg(long, default_value_t = 0.6)]
    fill: f64,
    /// Resolution of the map the scene is for (mapper.toml `cells_per_metre`; default:
    /// the built-in one): the floor must fit a map message at it.
    #[arg(long, default_value_t = aisle_mapper::MapConfig::default().cells_per_metre)]
    cells_per_metre: f64,
    /// The file to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn main(cmd: SceneCommand) -> ExitCode {
    let SceneCommand::Scene {
        command: SceneSub::Generate(a),
    } = cmd;
    let p = GenParams {
        aisles: a.aisles,
        length: a.length,
        seed: a.seed,
        aisle_width: a.aisle_width,
        cross_every: a.cross_every,
        cross_width: a.cross_width,
        packaging_depth: a.packaging_depth,
        fill: a.fill,
    };
    if let Some(problem) = p.problem() {
        return exit::fail(problem);
    }
    if !(a.cells_per_metre.is_finite() && a.cells_per_metre > 0.0) {
        return exit::fail(format!(
            "--cells-per-metre must be positive, got {}",
            a.cells_per_metre
        ));
    }
    let text = scene_gen::generate(&p);
    // The generator's own check: what it wrote must load as a scene...
    let scene = match Scene::parse(&a.out, &text) {
        Ok(s) => s,
        Err(e) => return exit::fail(format!("the generated scene is invalid: {e}")),
    };
    // ... and fit the messages and the reader that carry it (`check` asks the same).
    if let Some(why) = crate::check::scene_limits::problem(text.len(), &scene, a.cells_per_metre) {
        return exit::fail(format!(
            "nothing written to {}: the scene would have {why}; choose fewer or \
             narrower aisles (--aisles {}, --aisle-width {}) or a shorter --length {} \
             (--cells-per-metre {})",
            a.out.display(),
            a.aisles,
            a.aisle_width,
            a.length,
            a.cells_per_metre
        ));
    }
    if let Err(e) = std::fs::write(&a.out, &text) {
        return exit::fail(format!("{}: {e}", a.out.display()));
    }
    let layout = Layout::new(&p);
    println!(
        "wrote {}: {} bodies, {:.1} x {:.1} m",
        a.out.display(),
        scene.bodies.len(),
        layout.width,
        layout.height
    );
    ExitCode::SUCCESS
}
