//! A large warehouse scene generated from a few numbers and a seed, written as a
//! `warehouse.toml` (the format `scene.rs` reads): rack rows made of bays along the
//! picking aisles, cross aisles through them, a packaging area with shelves, tables,
//! staging pallets, movable pallet racks and loose boxes (clutter).
//!
//! The map frame has its origin at the south-west corner: x across the aisles, y along
//! them; the packaging area is at the south end. Every body is axis-aligned (yaw 0 or a
//! quarter turn), so [`Layout::aisles`] and the parts' bounding boxes say exactly what
//! is clear. The same [`GenParams`] give the same text, byte for byte. Knows nothing of
//! missions, maps or who reads the scene.

use crate::scene::Scene;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use std::fmt::Write as _;
use std::path::Path;

/// Wall thickness and height (metres).
const WALL: f64 = 0.2;
const WALL_H: f64 = 6.0;
/// A rack bay: length along its row, depth across it, four uprights and three decks.
const BAY_LEN: f64 = 2.7;
const BAY_DEPTH: f64 = 1.1;
/// The main cross aisle between the packaging area and the racks, and the one at the
/// north end.
const MAIN_CROSS: f64 = 4.0;
const BACK_CROSS: f64 = 3.0;
/// Storage levels: the floor and two decks; the top of each level's floor (metres).
const LEVEL_Z: [f64; 3] = [0.0, 1.6, 3.2];

/// What to generate. Lengths in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GenParams {
    /// Picking aisles (each between two rack rows).
    pub aisles: u32,
    /// Length of the racked part along y, cross aisles included.
    pub length: f64,
    pub seed: u64,
    pub aisle_width: f64,
    /// A cross aisle after at most this much racking.
    pub cross_every: f64,
    pub cross_width: f64,
    /// Depth (along y) of the packaging area.
    pub packaging_depth: f64,
    /// Chance that a storage slot holds a load.
    pub fill: f64,
}

impl GenParams {
    /// The defaults for `aisles` aisles of `length` metres.
    pub fn new(aisles: u32, length: f64, seed: u64) -> GenParams {
        GenParams {
            aisles,
            length,
            seed,
            aisle_width: 3.0,
            cross_every: 30.0,
            cross_width: 4.0,
            packaging_depth: 20.0,
            fill: 0.6,
        }
    }

    /// What is wrong with these numbers, naming the flag, or `None`.
    pub fn problem(&self) -> Option<String> {
        let pos = |v: f64, min: f64| v.is_finite() && v >= min;
        let bad = |flag: &str, v: f64, min: f64| format!("--{flag} must be >= {min}, got {v}");
        if !(1..=500).contains(&self.aisles) {
            return Some(format!("--aisles must be 1..=500, got {}", self.aisles));
        }
        for (flag, v, min) in [
            ("length", self.length, BAY_LEN),
            ("aisle-width", self.aisle_width, 1.0),
            ("cross-every", self.cross_every, BAY_LEN),
            ("cross-width", self.cross_width, 1.0),
            ("packaging-depth", self.packaging_depth, 12.0),
        ] {
            if !pos(v, min) {
                return Some(bad(flag, v, min));
            }
        }
        if self.length > 2000.0 || self.packaging_depth > 200.0 {
            return Some("--length must be <= 2000 and --packaging-depth <= 200".into());
        }
        // Wider than a real aisle is a hall with nothing in it, and its size (and the
        // generator's time and memory) grows with these without bound.
        for (flag, v, max) in [
            ("aisle-width", self.aisle_width, 50.0),
            ("cross-width", self.cross_width, 50.0),
            ("cross-every", self.cross_every, 2000.0),
        ] {
            if v > max {
                return Some(format!("--{flag} must be <= {max}, got {v}"));
            }
        }
        let width = Layout::new(self).width;
        if width > 2000.0 {
            return Some(format!(
                "the hall would be {width:.0} m wide (--aisles {} of --aisle-width {} between \
                 rack rows): at most 2000 m",
                self.aisles, self.aisle_width
            ));
        }
        if !(0.0..=1.0).contains(&self.fill) {
            return Some(format!("--fill must be in 0..=1, got {}", self.fill));
        }
        None
    }

    /// The command that generates this scene (for the file's header).
    pub fn command(&self) -> String {
        format!(
            "aisle scene generate --aisles {} --length {} --seed {} --aisle-width {} \
             --cross-every {} --cross-width {} --packaging-depth {} --fill {}",
            self.aisles,
            self.length,
            self.seed,
            self.aisle_width,
            self.cross_every,
            self.cross_width,
            self.packaging_depth,
            self.fill
        )
    }
}

/// Where things are: the outer size and the rectangles (x0, y0, x1, y1) that stay clear.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub width: f64,
    pub height: f64,
    /// Picking aisles and cross aisles: no body meets them.
    pub aisles: Vec<[f64; 4]>,
    /// y extent of the packaging area.
    pub packaging: [f64; 2],
}

impl Layout {
    pub fn new(p: &GenParams) -> Layout {
        let pitch = p.aisle_width + 2.0 * BAY_DEPTH;
        let width = 2.0 * WALL + f64::from(p.aisles) * pitch;
        let y_racks = WALL + p.packaging_depth + MAIN_CROSS;
        let y_end = y_racks + p.length;
        let height = y_end + BACK_CROSS + WALL;
        let mut aisles = vec![
            [WALL, y_racks - MAIN_CROSS, width - WALL, y_racks],
            [WALL, y_end, width - WALL, y_end + BACK_CROSS],
        ];
        for a in 0..p.aisles {
            let x0 = WALL + BAY_DEPTH + f64::from(a) * pitch;
            aisles.push([x0, y_racks, x0 + p.aisle_width, y_end]);
        }
        for (_, y1) in blocks(p, y_racks, y_end) {
            // The same test as `blocks` makes for another block to follow.
            if y1 + p.cross_width + BAY_LEN <= y_end + 1e-9 {
                aisles.push([WALL, y1, width - WALL, y1 + p.cross_width]);
            }
        }
        Layout {
            width,
            height,
            aisles,
            packaging: [WALL, WALL + p.packaging_depth],
        }
    }
}

/// The y extents of the rack blocks between cross aisles, each a whole number of bays.
fn blocks(p: &GenParams, y0: f64, y_end: f64) -> Vec<(f64, f64)> {
    let per_block = (p.cross_every / BAY_LEN).floor().max(1.0);
    let mut out = Vec::new();
    let mut y = y0;
    while y + BAY_LEN <= y_end + 1e-9 {
        let bays = per_block.min(((y_end - y) / BAY_LEN + 1e-9).floor());
        let y1 = y + bays * BAY_LEN;
        out.push((y, y1));
        y = y1 + p.cross_width;
    }
    out
}

const TEMPLATES: &str = r#"[templates.rack_bay]
# 2.7 m along the row, 1.1 m deep: four uprights and decks at 1.5, 3.1 and 4.7 m.
parts = [
  { center = [ 0.5,  1.3, 2.5], size = [0.08, 0.08, 5.0] },
  { center = [-0.5,  1.3, 2.5], size = [0.08, 0.08, 5.0] },
  { center = [ 0.5, -1.3, 2.5], size = [0.08, 0.08, 5.0] },
  { center = [-0.5, -1.3, 2.5], size = [0.08, 0.08, 5.0] },
  { center = [0.0, 0.0, 1.55], size = [0.9, 2.5, 0.1] },
  { center = [0.0, 0.0, 3.15], size = [0.9, 2.5, 0.1] },
  { center = [0.0, 0.0, 4.75], size = [0.9, 2.5, 0.1] },
]
"#;

/// The template of a pallet load standing at `z` (a 1.0 x 1.2 m pallet, goods on it).
fn load_template(level: usize, z: f64) -> String {
    format!(
        "[templates.load_l{level}]\nparts = [\n  {{ center = [0.0, 0.0, {:.3}], size = [1.0, 1.2, 0.144] }},\n  {{ center = [0.0, 0.0, {:.3}], size = [0.9, 1.1, 1.1] }},\n]\n",
        z + 0.072,
        z + 0.144 + 0.55
    )
}

const SEED_TEMPLATES: &str = r#"[templates.pallet_rack]
parts = [
  { center = [ 0.415,  0.375, 0.15],  size = [0.05, 0.05, 0.30] },
  { center = [-0.415,  0.375, 0.15],  size = [0.05, 0.05, 0.30] },
  { center = [-0.415, -0.375, 0.15],  size = [0.05, 0.05, 0.30] },
  { center = [ 0.415, -0.375, 0.15],  size = [0.05, 0.05, 0.30] },
  { center = [ 0.0,    0.0,   0.325], size = [0.88, 0.80, 0.05] },
  { center = [ 0.2,    0.0,   0.675], size = [0.38, 0.60, 0.65] },
  { center = [-0.2,    0.0,   0.60],  size = [0.36, 0.60, 0.50] },
]

[templates.eur_pallet_stack]
parts = [
  { center = [0.0, 0.0, 0.072], size = [1.2, 0.8, 0.144] },
  { center = [0.0, 0.0, 0.544], size = [1.0, 0.7, 0.8] },
]
"#;

/// Writes bodies as TOML, one `[[body]]` each, with positions rounded to the mm.
struct Writer {
    text: String,
    count: usize,
}

enum Shape<'a> {
    Size([f64; 3]),
    Template(&'a str),
}

impl Writer {
    fn body(&mut self, name: &str, kind: &str, is_static: bool, pose: [f64; 3], shape: Shape) {
        self.count += 1;
        let t = &mut self.text;
        let _ = write!(
            t,
            "\n[[body]]\nname = \"{name}\"\nkind = \"{kind}\"\nstatic = {is_static}\npose = [{:.3}, {:.3}, {}]\n",
            pose[0], pose[1], pose[2]
        );
        let _ = match shape {
            Shape::Size(s) => writeln!(t, "size = [{:.3}, {:.3}, {:.3}]", s[0], s[1], s[2]),
            Shape::Template(name) => writeln!(t, "template = \"{name}\""),
        };
    }
}

/// The scene as `warehouse.toml` text, with a header naming the command and the counts.
pub fn generate(p: &GenParams) -> String {
    let layout = Layout::new(p);
    let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
    let mut w = Writer {
        text: String::new(),
        count: 0,
    };
    walls(&mut w, &layout);
    racks(&mut w, &mut rng, p, &layout);
    packaging(&mut w, &mut rng, &layout);
    let mut head = format!(
        "# Generated by `{}`.\n# {:.1} x {:.1} m, {} bodies; map frame origin at the south-west corner,\n\
         # x across the {} aisles, y along them; the packaging area is at the south end.\n\n",
        p.command(),
        layout.width,
        layout.height,
        w.count,
        p.aisles
    );
    head.push_str(TEMPLATES);
    for (level, z) in LEVEL_Z.iter().enumerate() {
        head.push('\n');
        head.push_str(&load_template(level, *z));
    }
    head.push('\n');
    head.push_str(SEED_TEMPLATES);
    head + &w.text
}

/// [`generate`]d and parsed: the bodies a reader of the file would get.
pub fn generate_scene(p: &GenParams) -> Scene {
    Scene::parse(Path::new("generated.toml"), &generate(p))
        .expect("the generator writes a valid scene")
}

fn walls(w: &mut Writer, l: &Layout) {
    let (x_mid, y_mid) = (0.5 * l.width, 0.5 * l.height);
    let inner = l.height - 2.0 * WALL;
    for (name, pose, size) in [
        ("wall_south", [x_mid, 0.5 * WALL], [l.width, WALL, WALL_H]),
        (
            "wall_north",
            [x_mid, l.height - 0.5 * WALL],
            [l.width, WALL, WALL_H],
        ),
        ("wall_west", [0.5 * WALL, y_mid], [WALL, inner, WALL_H]),
        (
            "wall_east",
            [l.width - 0.5 * WALL, y_mid],
            [WALL, inner, WALL_H],
        ),
    ] {
        w.body(
            name,
            "wall",
            true,
            [pose[0], pose[1], 0.0],
            Shape::Size(size),
        );
    }
}

/// The rack rows (one against each side wall, two back to back between aisles), each
/// cut into blocks by the cross aisles, each bay with its loads.
fn racks(w: &mut Writer, rng: &mut ChaCha8Rng, p: &GenParams, l: &Layout) {
    let y_racks = WALL + p.packaging_depth + MAIN_CROSS;
    let pitch = p.aisle_width + 2.0 * BAY_DEPTH;
    let mut xs = vec![WALL + 0.5 * BAY_DEPTH];
    for a in 0..p.aisles {
        let x_aisle_end = WALL + BAY_DEPTH + f64::from(a) * pitch + p.aisle_width;
        xs.push(x_aisle_end + 0.5 * BAY_DEPTH);
        if a + 1 < p.aisles {
            xs.push(x_aisle_end + 1.5 * BAY_DEPTH);
        }
    }
    debug_assert!((xs[xs.len() - 1] + 0.5 * BAY_DEPTH - (l.width - WALL)).abs() < 1e-9);
    for (row, x) in xs.iter().enumerate() {
        for (block, (y0, y1)) in blocks(p, y_racks, y_racks + p.length).iter().enumerate() {
            let bays = ((y1 - y0) / BAY_LEN).round() as usize;
            for bay in 0..bays {
                let y = y0 + (bay as f64 + 0.5) * BAY_LEN;
                let name = format!("bay_r{row}_b{block}_{bay}");
                w.body(
                    &name,
                    "rack_bay",
                    true,
                    [*x, y, 0.0],
                    Shape::Template("rack_bay"),
                );
                for level in 0..LEVEL_Z.len() {
                    for (slot, dy) in [-0.65, 0.65].iter().enumerate() {
                        if rng.random_bool(p.fill) {
                            let t = format!("load_l{level}");
                            let pose = [*x, y + dy, 0.0];
                            let name = format!("{name}_l{level}s{slot}");
                            w.body(&name, "stored_load", true, pose, Shape::Template(&t));
                        }
                    }
                }
            }
        }
    }
}

/// The packaging area: shelves along the south wall, packing tables, staging pallets
/// and movable pallet racks in rows, loose boxes in the gaps, each on its own cell of
/// a 2.5 m grid so nothing overlaps and lanes stay between the rows.
fn packaging(w: &mut Writer, rng: &mut ChaCha8Rng, l: &Layout) {
    let [y0, y1] = l.packaging;
    let x_max = l.width - WALL;
    let mut n = 0;
    let mut x = WALL + 3.0;
    while x + 2.5 <= x_max {
        n += 1;
        w.body(
            &format!("shelf_{n}"),
            "shelf",
            true,
            [x, y0 + 0.55, 0.0],
            Shape::Size([3.9, 0.9, 2.6]),
        );
        x += 5.0;
    }
    let mut x = WALL + 4.0;
    n = 0;
    while x + 2.0 <= x_max {
        n += 1;
        let pose = [x, y0 + 4.0, 0.0];
        w.body(
            &format!("table_{n}"),
            "table",
            true,
            pose,
            Shape::Size([2.0, 1.0, 0.9]),
        );
        x += 8.0;
    }
    // Staging rows between y0 + 7 and y1 - 2 (the main cross aisle is beyond y1).
    let (mut pallets, mut carts, mut boxes, mut slot) = (0, 0, 0, 0u32);
    let mut y = y0 + 7.5;
    while y + 1.5 <= y1 - 1.0 {
        let mut x = WALL + 2.0;
        while x + 1.5 <= x_max {
            let jitter = [rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2)];
            let pose = [x + jitter[0], y + jitter[1]];
            let turn = if rng.random_bool(0.5) {
                std::f64::consts::FRAC_PI_2
            } else {
                0.0
            };
            // Kinds cycle over the slots (so even a small scene has each); every fifth
            // slot is drawn.
            slot += 1;
            let kind = match slot % 5 {
                0 | 1 => 0,
                2 => 4,
                3 => 6,
                _ => rng.random_range(0..10u32),
            };
            match kind {
                0..=3 => {
                    pallets += 1;
                    let name = format!("pallet_{pallets}");
                    w.body(
                        &name,
                        "eur_pallet",
                        false,
                        [pose[0], pose[1], turn],
                        Shape::Template("eur_pallet_stack"),
                    );
                }
                4..=5 => {
                    carts += 1;
                    let name = format!("rack_{carts}");
                    w.body(
                        &name,
                        "pallet_rack",
                        false,
                        [pose[0], pose[1], turn],
                        Shape::Template("pallet_rack"),
                    );
                }
                6..=7 => {
                    boxes += 1;
                    let s = [
                        rng.random_range(0.3..0.8),
                        rng.random_range(0.3..0.8),
                        rng.random_range(0.3..1.0),
                    ];
                    w.body(
                        &format!("box_{boxes}"),
                        "box",
                        false,
                        [pose[0], pose[1], turn],
                        Shape::Size(s),
                    );
                }
                _ => {}
            }
            x += 2.5;
        }
        y += 3.5;
    }
}

#[cfg(test)]
mod tests;
