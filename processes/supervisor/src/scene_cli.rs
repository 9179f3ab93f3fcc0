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
    // The map must cover the floor, or the robot cannot be sent beyond the built-in
    // map's 20 x 30 m: say what mapper.toml needs.
    let band = aisle_mapper::MapConfig::default().boundary_band;
    let (x0, y0, w, h) = covering_map(&scene, band);
    println!(
        "cover it with the map, in mapper.toml: origin = [{x0:.1}, {y0:.1}], \
         size = [{w:.1}, {h:.1}], boundary_band = {band:.1} (at cells_per_metre = {} that is \
         {:.0} x {:.0} cells)",
        a.cells_per_metre,
        w * a.cells_per_metre,
        h * a.cells_per_metre
    );
    ExitCode::SUCCESS
}

/// The smallest map (origin x, y and size, metres, outward to a decimetre) whose
/// interior (the map less its boundary band `band`, where the robot may stand) covers
/// every body of `scene`.
fn covering_map(scene: &Scene, band: f64) -> (f64, f64, f64, f64) {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for b in &scene.bodies {
        for (x, y) in b.footprint().corners(&b.pose) {
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    let out = |v: f64, dir: f64| dir * ((dir * v + band) * 10.0).ceil() / 10.0;
    let (x0, y0, x1, y1) = (out(x0, -1.0), out(y0, -1.0), out(x1, 1.0), out(y1, 1.0));
    (x0, y0, x1 - x0, y1 - y0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_covering_map_holds_every_body_within_its_interior() {
        let dir = aisle_config::testing::shipped_dir().join("large");
        let scene = Scene::load(&dir.join("warehouse.toml")).unwrap();
        let (x0, y0, w, h) = covering_map(&scene, 1.0);
        let inside = |(x, y): (f64, f64)| {
            x >= x0 + 1.0 && y >= y0 + 1.0 && x <= x0 + w - 1.0 && y <= y0 + h - 1.0
        };
        assert!(
            scene
                .bodies
                .iter()
                .all(|b| b.footprint().corners(&b.pose).into_iter().all(inside))
        );
        // Tight: the 99.2 x 199.4 m hall, a band of 1 m each side, a decimetre's rounding.
        assert!(w <= 99.2 + 2.0 + 0.2 && h <= 199.4 + 2.0 + 0.2, "{w} x {h}");
    }
}
