//! How large a scene can be and still run: the limits that come from fixed-capacity
//! messages and the config reader, stated once here from their sources (not copied as
//! numbers) for `aisle scene generate` (the generated file, before it is written) and
//! for `check` (a hand-written one). Knows the scene's size, its bodies and the map's
//! resolution, nothing of missions.
//!
//! - the file: at most `aisle_config::MAX_CONFIG_BYTES` (every config file is read
//!   through `read_capped`);
//! - movable bodies: at most `aisle_simulator::MAX_MOVABLE_BODIES` (`WorldTruth` holds
//!   `MAX_BODIES`, of which `MAX_CONTACTS` are kept for static bodies in contact);
//! - the floor the bodies span: at most `MAX_GLOBAL_GRID_SIDE` cells a side and
//!   `MAX_GLOBAL_GRID_CELLS` in all at the map's resolution (`GlobalGrid`), or the map
//!   cannot hold them.

use aisle_config::scene::Scene;

/// What would not fit, naming the quantity, its value and the limit with its source.
pub fn problem(bytes: usize, scene: &Scene, cells_per_metre: f64) -> Option<String> {
    let max_bytes = aisle_config::MAX_CONFIG_BYTES;
    if bytes as u64 > max_bytes {
        return Some(format!(
            "{bytes} bytes, more than the {max_bytes} ({} MiB) a config file may have",
            max_bytes >> 20
        ));
    }
    let movable = scene.movable_bodies().count();
    let max_movable = aisle_simulator::MAX_MOVABLE_BODIES;
    if movable > max_movable {
        return Some(format!(
            "{movable} movable bodies (`static = false`), more than the {max_movable} the \
             simulator's ground truth holds (WorldTruth: {} bodies, {} of them kept for \
             static bodies in contact); static bodies: any number",
            aisle_messages::MAX_BODIES,
            aisle_messages::MAX_CONTACTS
        ));
    }
    let (w, h) = span(scene)?;
    let max_side = aisle_messages::MAX_GLOBAL_GRID_SIDE as f64 / cells_per_metre;
    if w.max(h) > max_side + 1e-9 {
        return Some(format!(
            "bodies spanning {w:.1} x {h:.1} m, a side longer than the {max_side} m a map \
             holds at {cells_per_metre} cells/m (GlobalGrid: at most {} cells a side)",
            aisle_messages::MAX_GLOBAL_GRID_SIDE
        ));
    }
    let cells = (w * cells_per_metre).ceil() * (h * cells_per_metre).ceil();
    let max_cells = aisle_messages::MAX_GLOBAL_GRID_CELLS;
    if cells > max_cells as f64 {
        return Some(format!(
            "bodies spanning {w:.1} x {h:.1} m, {cells} cells at {cells_per_metre} cells/m: \
             more than the {max_cells} cells a map holds (GlobalGrid)"
        ));
    }
    None
}

/// The width and depth (m) of the rectangle around every body's footprint; `None`
/// without bodies.
fn span(scene: &Scene) -> Option<(f64, f64)> {
    let corners = scene
        .bodies
        .iter()
        .flat_map(|b| b.footprint().corners(&b.pose));
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    let mut any = false;
    for (x, y) in corners {
        any = true;
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    any.then_some((x1 - x0, y1 - y0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::testing::shipped;

    fn body(name: &str, movable: bool, x: f64) -> String {
        format!(
            "[[body]]\nname = \"{name}\"\nkind = \"box\"\nstatic = {}\npose = [{x}, 0.0, 0.0]\n\
             size = [0.5, 0.5, 0.5]\n",
            !movable
        )
    }

    #[test]
    fn the_limits_come_from_the_messages_and_name_value_and_limit() {
        let text = std::fs::read_to_string(shipped("warehouse.toml")).unwrap();
        let scene = Scene::parse(&shipped("warehouse.toml"), &text).unwrap();
        assert_eq!(problem(text.len(), &scene, 10.0), None);
        let e = problem(17 << 20, &scene, 10.0).unwrap();
        assert!(e.contains("16777216 (16 MiB)"), "{e}");
        let many: String = (0..=aisle_simulator::MAX_MOVABLE_BODIES)
            .map(|i| body(&format!("b{i}"), true, i as f64))
            .collect();
        let scene = Scene::parse(&shipped("warehouse.toml"), &many).unwrap();
        let e = problem(many.len(), &scene, 0.1).unwrap();
        assert!(
            e.contains("225 movable bodies") && e.contains("the 224"),
            "{e}"
        );
        // Two static bodies 820 m apart: over 819.2 m at 10 cells/m, fine at 5.
        let far = body("a", false, 0.0) + &body("b", false, 819.5);
        let scene = Scene::parse(&shipped("warehouse.toml"), &far).unwrap();
        let e = problem(far.len(), &scene, 10.0).unwrap();
        assert!(e.contains("820.0 x 0.5 m") && e.contains("819.2 m"), "{e}");
        assert_eq!(problem(far.len(), &scene, 5.0), None);
        // A square hall of 410 m a side: its sides fit, its cells (2^24 at most) not.
        let square = [(0.0, 0.0), (409.5, 0.0), (0.0, 409.5)]
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| {
                body(&format!("c{i}"), false, x).replace(
                    &format!("pose = [{x}, 0.0, 0.0]"),
                    &format!("pose = [{x}, {y}, 0.0]"),
                )
            })
            .collect::<String>();
        let scene = Scene::parse(&shipped("warehouse.toml"), &square).unwrap();
        let e = problem(square.len(), &scene, 10.0).unwrap();
        assert!(e.contains("16777216 cells"), "{e}");
    }
}
