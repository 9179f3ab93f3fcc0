//! Can a leg's goal be reached at all on the static map? A necessary condition, checked
//! before launch: the goal's cell must be connected to the start's cell through cells
//! where the robot's centre may stand, for the leg's footprint.
//!
//! **Why not the planner's own search.** Running Hybrid A* here would give the
//! planner's verdict, but not a proof: a search that runs out of its expansion budget
//! (the carrying legs) says nothing about feasibility, an approach leg ends under
//! a rack the search would have to dock into, and the planner's collision model (hard
//! margin, docking moves) is changing. So this module proves infeasibility instead, with
//! the collision rule every version of the planner shares: a pose collides when the
//! footprint rectangle (margin 0, the weakest) touches an occupied cell of the static
//! map or leaves the grid. It refuses only what no planner can drive, whatever its
//! margins, costs and budget:
//!
//! - whatever the heading, the footprint covers the disc of its inscribed radius `r`;
//!   an occupied square reaching into that disc is touched. For any point of a cell
//!   whose centre is within `r - (√2 - 1)·res/2` of an occupied cell's centre, that
//!   cell's square reaches into the disc (half a cell nearer than its centre, at most
//!   half a diagonal away from the cell's own centre). Such a cell is *blocked*: no pose
//!   with its centre there is free;
//! - a continuous path of the robot's centre crosses cells that share an edge or a
//!   corner, each holding a free pose, so the start's and the goal's cells are in one
//!   8-connected component of unblocked cells. If they are not, no path exists.
//!
//! The static map holds no movable body: an approach leg's goal under a rack, and the
//! start of a leg under the rack just set down, are free here, as they should be (the
//! scene's bodies are [`super::goals`]'s job). Cost: a disc stamped around every occupied
//! cell and one flood fill per footprint radius, a few milliseconds on the seed map.
//! Knows nothing of headings, bodies or the planner's search.

use aisle_geometry::{FREE, GridView};

/// What the static map says about a leg's goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The goal's cell is connected to the start's (a path may exist).
    Connected,
    /// No pose with its centre in the goal's cell is free, whatever the heading.
    GoalBlocked,
    /// The start's cell is blocked too: nothing can be proven (the start is checked
    /// against the scene's bodies elsewhere).
    StartBlocked,
    /// Both cells are free but in different components: no path exists.
    Disconnected,
}

/// The 8 neighbours of a cell: a path of the robot's centre moves between cells that
/// share an edge or a corner.
pub(crate) const NEIGHBOURS: [(i64, i64); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (1, -1),
    (-1, 1),
    (-1, -1),
];

/// Connected components of the static map's unblocked cells, per footprint radius.
pub struct Reach<'a> {
    map: GridView<'a>,
    /// (radius bits, component label per cell; 0 = blocked).
    labels: Vec<(u64, Vec<u32>)>,
}

impl<'a> Reach<'a> {
    pub fn new(map: GridView<'a>) -> Reach<'a> {
        Reach {
            map,
            labels: Vec::new(),
        }
    }

    /// Whether the robot with inscribed radius `r` (metres) can get from `from` to `to`
    /// (map-frame positions) on the static map, as far as connectivity can tell.
    pub fn verdict(&mut self, from: (f64, f64), to: (f64, f64), r: f64) -> Verdict {
        let map = self.map;
        let index = |(x, y): (f64, f64)| {
            let c = map.cell_of(x, y);
            map.contains_cell(c)
                .then(|| c.iy as usize * map.width + c.ix as usize)
        };
        let labels = self.labels_for(r);
        let label = |p| index(p).map_or(0, |i| labels[i]);
        match (label(from), label(to)) {
            (_, 0) => Verdict::GoalBlocked,
            (0, _) => Verdict::StartBlocked,
            (a, b) if a == b => Verdict::Connected,
            _ => Verdict::Disconnected,
        }
    }

    fn labels_for(&mut self, r: f64) -> &[u32] {
        let key = r.to_bits();
        let at = match self.labels.iter().position(|(k, _)| *k == key) {
            Some(at) => at,
            None => {
                let blocked = blocked_cells(&self.map, r);
                self.labels.push((key, components(&self.map, &blocked)));
                self.labels.len() - 1
            }
        };
        &self.labels[at].1
    }
}

/// Cells where no pose of a footprint with inscribed radius `r` is free (see the module
/// documentation): occupied cells, and cells whose centre is nearer than
/// `r - (√2 - 1)·res/2` to an occupied cell's centre or to one outside the grid.
fn blocked_cells(map: &GridView, r: f64) -> Vec<bool> {
    let (w, h) = (map.width, map.height);
    let reach = (r - (std::f64::consts::SQRT_2 - 1.0) * 0.5 * map.resolution) / map.resolution;
    let mut blocked: Vec<bool> = map.cells.iter().map(|&c| c != FREE).collect();
    if reach <= 0.0 {
        return blocked;
    }
    let n = reach.ceil() as i64;
    let disc: Vec<(i64, i64)> = (-n..=n)
        .flat_map(|dy| (-n..=n).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| (((dx * dx + dy * dy) as f64).sqrt()) < reach)
        .collect();
    let free = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && x < w as i64
            && y < h as i64
            && map.cells[y as usize * w + x as usize] == FREE
    };
    for iy in 0..h as i64 {
        for ix in 0..w as i64 {
            // The occupied cell nearest to a free cell has a free neighbour (the one a
            // step towards that cell is nearer still), so only such cells need a disc.
            let edge = !free(ix, iy) && NEIGHBOURS.iter().any(|&(dx, dy)| free(ix + dx, iy + dy));
            if !edge {
                continue;
            }
            for &(dx, dy) in &disc {
                let (x, y) = (ix + dx, iy + dy);
                if x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
                    blocked[y as usize * w + x as usize] = true;
                }
            }
        }
    }
    // Outside the grid counts as occupied: the nearest outside cell centre is one whole
    // cell beyond the edge, straight across.
    for iy in 0..h {
        for ix in 0..w {
            let edge = ix.min(iy).min(w - 1 - ix).min(h - 1 - iy) + 1;
            if (edge as f64) < reach {
                blocked[iy * w + ix] = true;
            }
        }
    }
    blocked
}

/// 8-connected components of the unblocked cells, labelled from 1 (0: blocked).
fn components(map: &GridView, blocked: &[bool]) -> Vec<u32> {
    let (w, h) = (map.width as i64, map.height as i64);
    let mut label = vec![0u32; blocked.len()];
    let mut next = 0u32;
    let mut stack = Vec::new();
    for seed in 0..blocked.len() {
        if blocked[seed] || label[seed] != 0 {
            continue;
        }
        next += 1;
        label[seed] = next;
        stack.push(seed);
        while let Some(i) = stack.pop() {
            let (x, y) = ((i as i64) % w, (i as i64) / w);
            for (dx, dy) in NEIGHBOURS {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let j = (ny * w + nx) as usize;
                if !blocked[j] && label[j] == 0 {
                    label[j] = next;
                    stack.push(j);
                }
            }
        }
    }
    label
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

    /// A 10 x 10 m map at 0.1 m with a closed square room (walls 0.2 m thick) whose
    /// inside spans x, y in 4..6 m, and a wall at x 8.0..8.2 with a gap in y 4.5..`gap_top`.
    fn room(gap_top: f64) -> GridMap {
        let mut m = GridMap::new_free(0.0, 0.0, 0.1, 10.0, 10.0).unwrap();
        let mut fill = |x0: f64, x1: f64, y0: f64, y1: f64| {
            let v = m.view();
            let (a, b) = (
                v.cell_of(x0 + 1e-6, y0 + 1e-6),
                v.cell_of(x1 - 1e-6, y1 - 1e-6),
            );
            for iy in a.iy..=b.iy {
                for ix in a.ix..=b.ix {
                    m.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
                }
            }
        };
        fill(3.8, 6.2, 3.8, 4.0);
        fill(3.8, 6.2, 6.0, 6.2);
        fill(3.8, 4.0, 3.8, 6.2);
        fill(6.0, 6.2, 3.8, 6.2);
        fill(8.0, 8.2, 0.0, 4.5);
        fill(8.0, 8.2, gap_top, 10.0);
        m
    }

    #[test]
    fn a_goal_in_a_closed_room_is_disconnected() {
        let m = room(5.5);
        let mut reach = Reach::new(m.view());
        assert_eq!(
            reach.verdict((1.0, 1.0), (5.0, 5.0), 0.215),
            Verdict::Disconnected
        );
        // Inside the room, the robot gets around.
        assert_eq!(
            reach.verdict((4.5, 4.5), (5.5, 5.5), 0.215),
            Verdict::Connected
        );
    }

    #[test]
    fn a_gap_narrower_than_the_footprint_separates_only_the_wider_footprint() {
        // A 1.0 m gap: wide enough for 0.43 m, and for 0.8 m only at its middle.
        let m = room(5.5);
        let mut reach = Reach::new(m.view());
        assert_eq!(
            reach.verdict((1.0, 1.0), (9.0, 1.0), 0.215),
            Verdict::Connected
        );
        assert_eq!(
            reach.verdict((1.0, 1.0), (9.0, 1.0), 0.4),
            Verdict::Connected
        );
        // A 0.6 m gap: the robot alone passes, the carrying footprint (0.8 m) cannot.
        let m = room(5.1);
        let mut reach = Reach::new(m.view());
        assert_eq!(
            reach.verdict((1.0, 1.0), (9.0, 1.0), 0.215),
            Verdict::Connected
        );
        assert_eq!(
            reach.verdict((1.0, 1.0), (9.0, 1.0), 0.4),
            Verdict::Disconnected
        );
    }

    #[test]
    fn cells_against_a_wall_or_the_edge_are_blocked_and_a_start_there_proves_nothing() {
        let m = room(5.5);
        let mut reach = Reach::new(m.view());
        // 0.05 m from the room's outer wall face: the inscribed disc reaches into it.
        assert_eq!(
            reach.verdict((1.0, 1.0), (3.75, 5.0), 0.215),
            Verdict::GoalBlocked
        );
        assert_eq!(
            reach.verdict((1.0, 1.0), (0.05, 5.0), 0.215),
            Verdict::GoalBlocked
        );
        assert_eq!(
            reach.verdict((0.05, 5.0), (1.0, 1.0), 0.215),
            Verdict::StartBlocked
        );
        // Inside a wall, and outside the grid.
        assert_eq!(
            reach.verdict((1.0, 1.0), (3.9, 5.0), 0.0),
            Verdict::GoalBlocked
        );
        assert_eq!(
            reach.verdict((1.0, 1.0), (-3.0, 5.0), 0.215),
            Verdict::GoalBlocked
        );
    }

    /// Distance from `p` to the nearest of the `occupied` squares (centres, 0.1 m
    /// cells) or to the outside of the grid.
    fn clearance(m: &GridMap, occupied: &[(f64, f64)], (x, y): (f64, f64)) -> f64 {
        let (x0, y0, x1, y1) = m.view().bounds();
        let edge = (x - x0).min(x1 - x).min(y - y0).min(y1 - y);
        occupied.iter().fold(edge, |d, &(cx, cy)| {
            let dx = ((x - cx).abs() - 0.05).max(0.0);
            let dy = ((y - cy).abs() - 0.05).max(0.0);
            d.min(dx.hypot(dy))
        })
    }

    #[test]
    fn no_position_clear_by_the_inscribed_radius_is_blocked() {
        // Soundness: wherever the footprint's inscribed disc clears every occupied
        // square and the grid's edge, some heading may be free, so the cell must not
        // be blocked. Points on a lattice that does not line up with the cells.
        let m = room(5.1);
        let v = m.view();
        let occupied: Vec<(f64, f64)> = (0..v.width as i64)
            .flat_map(|ix| (0..v.height as i64).map(move |iy| CellIndex { ix, iy }))
            .filter(|&c| v.occupied_inside(c))
            .map(|c| v.cell_center(c))
            .collect();
        let points: Vec<((f64, f64), f64)> = (0..90)
            .flat_map(|i| (0..40).map(move |j| (0.0137 * i as f64, 3.0 + 0.1013 * j as f64)))
            .flat_map(|(dx, y)| [(3.0 + dx, y), (7.0 + dx, y), (dx + 1e-3, y)])
            .map(|p| (p, clearance(&m, &occupied, p)))
            .collect();
        let mut reach = Reach::new(v);
        for r in [0.215, 0.4] {
            let mut clear = 0;
            for &(p, d) in &points {
                if d >= r {
                    clear += 1;
                    assert_ne!(
                        reach.verdict((2.0, 2.0), p, r),
                        Verdict::GoalBlocked,
                        "{p:?} clears by {d} >= {r}"
                    );
                }
            }
            assert!(clear > 100, "{clear} clear points only");
        }
    }
}
