use super::*;
use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

#[test]
fn goes_around_a_wall_and_proves_enclosure() {
    let mut g = GridMap::new_free(0.0, 0.0, 0.1, 6.0, 4.0).unwrap();
    // A wall at x = 3.0 from y = 0 up to y = 3.0, leaving a gap above.
    for iy in 0..30 {
        g.set(CellIndex { ix: 30, iy }, OCCUPIED_STATIC);
    }
    let mut dm = DistanceMap::default();
    dm.ensure(&g.view());
    for eager in [true, false] {
        let mut h = GridHeuristic::default();
        let ends = ((4.5, 1.0), (1.5, 1.0));
        assert!(h.begin(&dm, 0.2, 0.1, ends, eager));
        let straight = 3.0;
        let around = h.metres(&dm, 1.5, 1.0).unwrap();
        assert!(around > straight + 2.0, "{around}");
        assert!(h.metres(&dm, 4.6, 1.0).unwrap() < 0.2);
    }
    // Close the gap: the left side is unreachable.
    for iy in 30..40 {
        g.set(CellIndex { ix: 30, iy }, OCCUPIED_STATIC);
    }
    dm.ensure(&g.view());
    for eager in [true, false] {
        let mut h = GridHeuristic::default();
        assert!(h.begin(&dm, 0.2, 0.2, ((4.5, 1.0), (1.5, 1.0)), eager));
        assert_eq!(h.metres(&dm, 1.5, 1.0), None);
        assert!(h.metres(&dm, 5.0, 2.0).is_some());
    }
}

/// The backward search stopped early gives every queried cell the distance of a search
/// over the whole map, in any order of queries, and across map changes.
#[test]
fn lazy_queries_equal_the_whole_search() {
    let mut g = GridMap::new_free(0.0, 0.0, 0.05, 30.0, 20.0).unwrap();
    let (w, h) = (g.view().width as i64, g.view().height as i64);
    let mut next = crate::tests::stream(0x9e37_79b9_7f4a_7c15);
    // Walls of random length: detours for the distance, pockets it cannot reach.
    for _ in 0..60 {
        let (x0, y0, len, vertical) = (next(w), next(h), 10 + next(120), next(2) == 0);
        for k in 0..len {
            let c = if vertical {
                CellIndex { ix: x0, iy: y0 + k }
            } else {
                CellIndex { ix: x0 + k, iy: y0 }
            };
            g.set(c, OCCUPIED_STATIC);
        }
    }
    let mut dm = DistanceMap::default();
    let (mut whole, mut lazy) = (GridHeuristic::default(), GridHeuristic::default());
    let mut compared = (0, 0);
    for round in 0..4 {
        dm.ensure(&g.view());
        let point = |k: i64| {
            (
                0.1 + k as f64 * 0.0337 % 29.8,
                0.1 + k as f64 * 0.0713 % 19.8,
            )
        };
        let (goal, start) = (point(next(100_000)), point(next(100_000)));
        let ok = whole.begin(&dm, 0.3, 0.1, (goal, start), true);
        assert_eq!(ok, lazy.begin(&dm, 0.3, 0.1, (goal, start), false));
        if !ok {
            continue;
        }
        let reachable = whole.settled;
        for _ in 0..3000 {
            let (x, y) = point(next(100_000));
            let a = whole.metres(&dm, x, y);
            assert_eq!(
                a.map(f64::to_bits),
                lazy.metres(&dm, x, y).map(f64::to_bits)
            );
            compared.0 += usize::from(a.is_some());
            compared.1 += usize::from(a.is_none());
        }
        assert!(lazy.settled <= reachable);
        lazy.complete(&dm);
        assert_eq!(lazy.settled, reachable, "round {round}");
        // Move some walls for the next round.
        for _ in 0..5 {
            let (x0, y0) = (next(w), next(h));
            for k in 0..40 {
                g.set(CellIndex { ix: x0 + k, iy: y0 }, OCCUPIED_STATIC);
            }
        }
    }
    assert!(compared.0 > 3000 && compared.1 > 10, "{compared:?}");
}

/// A request to the same goal resumes the lazy search the last one left (another start,
/// the same distances, its closed cells kept); another goal cell, another body or a new
/// map geometry starts afresh.
#[test]
fn a_resumed_search_answers_as_a_fresh_one() {
    let mut g = GridMap::new_free(0.0, 0.0, 0.05, 30.0, 20.0).unwrap();
    let (w, h) = (g.view().width as i64, g.view().height as i64);
    let mut next = crate::tests::stream(0x2545_f491_4f6c_dd1d);
    for _ in 0..60 {
        let (x0, y0, len) = (next(w), next(h), 10 + next(120));
        for k in 0..len {
            g.set(CellIndex { ix: x0 + k, iy: y0 }, OCCUPIED_STATIC);
        }
    }
    let mut dm = DistanceMap::default();
    dm.ensure(&g.view());
    let point = |k: i64| {
        (
            0.1 + k as f64 * 0.0337 % 29.8,
            0.1 + k as f64 * 0.0713 % 19.8,
        )
    };
    let (mut whole, mut lazy) = (GridHeuristic::default(), GridHeuristic::default());
    let goal = loop {
        let goal = point(next(100_000));
        if whole.begin(&dm, 0.3, 0.1, (goal, goal), true) {
            break goal;
        }
    };
    let reachable = whole.settled;
    let (mut resumed, mut compared) = (0, 0);
    for round in 0..12 {
        let start = point(next(100_000));
        let before = lazy.settled;
        assert!(lazy.begin(&dm, 0.3, 0.1, (goal, start), false));
        if round > 0 {
            // Resumed: nothing reset, the cells closed so far still counted.
            assert_eq!(lazy.settled, before, "round {round}");
            resumed += 1;
        }
        for (x, y) in std::iter::once(start).chain((0..300).map(|_| point(next(100_000)))) {
            let a = whole.metres(&dm, x, y);
            assert_eq!(
                a.map(f64::to_bits),
                lazy.metres(&dm, x, y).map(f64::to_bits)
            );
            compared += 1;
        }
        assert!(lazy.settled <= reachable);
    }
    lazy.complete(&dm);
    assert_eq!(lazy.settled, reachable);
    assert!(resumed == 11 && compared > 3000);
    // The goal in another cell, another body, a map change: each starts afresh.
    let other = (goal.0 + 0.35, goal.1);
    let _ = lazy.begin(&dm, 0.3, 0.1, (other, goal), false);
    assert_eq!(lazy.settled, 0);
    let _ = lazy.begin(&dm, 0.3, 0.1, (goal, other), false);
    lazy.complete(&dm);
    assert!(lazy.begin(&dm, 0.25, 0.1, (goal, other), false));
    assert_eq!(lazy.settled, 0);
    // A map change is repaired (the next test); a change it cannot follow (the map
    // rebuilt: another geometry) starts afresh.
    lazy.complete(&dm);
    let mut wider = GridMap::new_free(0.0, 0.0, 0.05, 31.0, 20.0).unwrap();
    wider.set(CellIndex { ix: 0, iy: 0 }, OCCUPIED_STATIC);
    dm.ensure(&wider.view());
    let _ = lazy.begin(&dm, 0.25, 0.1, (goal, other), false);
    assert_eq!(lazy.settled, 0);
}

/// A request to the same goal after map changes repairs the lazy search rather than
/// flooding again: walls added near and far, then taken away again, every answer that of
/// a flood of the changed map, and the closed cells counted as a flood would.
#[test]
fn a_repaired_search_answers_as_a_flood_of_the_changed_map() {
    use aisle_geometry::FREE;
    let mut g = GridMap::new_free(0.0, 0.0, 0.05, 30.0, 20.0).unwrap();
    let (w, h) = (g.view().width as i64, g.view().height as i64);
    let mut next = crate::tests::stream(0x6a09_e667_f3bc_c908);
    for _ in 0..50 {
        let (x0, y0, len) = (next(w), next(h), 10 + next(120));
        for k in 0..len {
            g.set(CellIndex { ix: x0, iy: y0 + k }, OCCUPIED_STATIC);
        }
    }
    let point = |k: i64| {
        (
            0.1 + k as f64 * 0.0337 % 29.8,
            0.1 + k as f64 * 0.0713 % 19.8,
        )
    };
    let mut dm = DistanceMap::default();
    dm.force_lazy = true;
    dm.ensure(&g.view());
    let (mut whole, mut lazy) = (GridHeuristic::default(), GridHeuristic::default());
    let goal = loop {
        let goal = point(next(100_000));
        if whole.begin(&dm, 0.3, 0.1, (goal, goal), true) {
            break goal;
        }
    };
    let (mut repaired, mut cut, mut compared, mut walls) = (0, 0, 0, Vec::new());
    for round in 0..16 {
        let start = point(next(100_000));
        if round > 0 {
            // Add a wall (odd rounds take the last one away again): cells blocked and
            // freed, sometimes near the goal, sometimes far.
            if round % 2 == 1 || walls.is_empty() {
                let (x0, y0) = (next(w - 60), next(h));
                walls.push((x0, y0));
                for k in 0..60 {
                    g.set(CellIndex { ix: x0 + k, iy: y0 }, OCCUPIED_STATIC);
                }
            } else if let Some((x0, y0)) = walls.pop() {
                for k in 0..60 {
                    g.set(CellIndex { ix: x0 + k, iy: y0 }, FREE);
                }
            }
            dm.ensure(&g.view());
        }
        let ok = whole.begin(&dm, 0.3, 0.1, (goal, start), true);
        let reachable = whole.settled;
        let before = lazy.settled;
        if !lazy.begin(&dm, 0.3, 0.1, (goal, start), false) {
            assert!(!ok, "round {round}");
            continue;
        }
        assert!(ok, "round {round}");
        // Repaired (or resumed): the kept cells stay counted.
        repaired += usize::from(round > 0 && lazy.settled > 0);
        // Cut back where the change reached, not emptied.
        cut += usize::from(round > 0 && lazy.settled > 0 && lazy.settled < before);
        let points = std::iter::once(start).chain((0..400).map(|_| point(next(100_000))));
        compared += same_answers(&mut whole, &mut lazy, &dm, points, round);
        if round % 4 == 3 {
            lazy.complete(&dm);
            assert_eq!(lazy.settled, reachable, "round {round}");
        }
    }
    assert!(
        repaired >= 10 && cut >= 4 && compared > 5000,
        "{repaired} {cut} {compared}"
    );
}

/// A detection appearing or going away (cells blocked only, or freed only) is repaired in
/// place (`incremental.rs`): every answer that of a flood of the changed map, through
/// many changes in a row, near the goal and far, with the closed cells still counted as
/// a flood would; a change that blocks and frees at once takes the cut (`repair.rs`).
#[test]
fn an_in_place_repair_answers_as_a_flood_of_the_changed_map() {
    use aisle_geometry::FREE;
    let mut g = GridMap::new_free(0.0, 0.0, 0.05, 30.0, 20.0).unwrap();
    let (w, h) = (g.view().width as i64, g.view().height as i64);
    let mut next = crate::tests::stream(0xbb67_ae85_84ca_a73b);
    for _ in 0..50 {
        let (x0, y0, len) = (next(w), next(h), 10 + next(120));
        for k in 0..len {
            g.set(CellIndex { ix: x0 + k, iy: y0 }, OCCUPIED_STATIC);
        }
    }
    let point = |k: i64| {
        (
            0.1 + k as f64 * 0.0337 % 29.8,
            0.1 + k as f64 * 0.0713 % 19.8,
        )
    };
    let mut dm = DistanceMap::default();
    dm.force_lazy = true;
    dm.ensure(&g.view());
    let (mut whole, mut lazy) = (GridHeuristic::default(), GridHeuristic::default());
    let goal = loop {
        let goal = point(next(100_000));
        if whole.begin(&dm, 0.3, 0.1, (goal, goal), true) {
            break goal;
        }
    };
    let (mut compared, mut boxes) = (0, Vec::new());
    let set_box = |g: &mut GridMap, (x0, y0): (i64, i64), v: u8| {
        for k in 0..49 {
            g.set(
                CellIndex {
                    ix: x0 + k % 7,
                    iy: y0 + k / 7,
                },
                v,
            );
        }
    };
    for round in 0..40 {
        let start = point(next(100_000));
        if round > 0 {
            // A box of detections added, or the oldest taken away; every fifth round
            // both at once.
            let add = round % 5 == 4 || boxes.len() < 2 || next(2) == 0;
            let remove = round % 5 == 4 || !add;
            if remove && !boxes.is_empty() {
                let b = boxes.remove(0);
                set_box(&mut g, b, FREE);
            }
            if add {
                let b = (next(w - 7), next(h - 7));
                boxes.push(b);
                set_box(&mut g, b, OCCUPIED_STATIC);
            }
            dm.ensure(&g.view());
        }
        let ok = whole.begin(&dm, 0.3, 0.1, (goal, start), true);
        let reachable = whole.settled;
        if !lazy.begin(&dm, 0.3, 0.1, (goal, start), false) {
            assert!(!ok, "round {round}");
            continue;
        }
        assert!(ok, "round {round}");
        let points = std::iter::once(start).chain((0..300).map(|_| point(next(100_000))));
        compared += same_answers(&mut whole, &mut lazy, &dm, points, round);
        if round % 7 == 6 {
            lazy.complete(&dm);
            assert_eq!(lazy.settled, reachable, "round {round}");
        }
    }
    assert!(
        lazy.in_place >= 15 && compared > 10_000,
        "{} {compared}",
        lazy.in_place
    );
}

/// Asserts that `lazy` answers every point as `whole` does, bit for bit (round `round`);
/// how many it compared.
fn same_answers(
    whole: &mut GridHeuristic,
    lazy: &mut GridHeuristic,
    dm: &DistanceMap,
    points: impl Iterator<Item = (f64, f64)>,
    round: usize,
) -> usize {
    let mut compared = 0;
    for (x, y) in points {
        assert_eq!(
            whole.metres(dm, x, y).map(f64::to_bits),
            lazy.metres(dm, x, y).map(f64::to_bits),
            "round {round}"
        );
        compared += 1;
    }
    compared
}

/// On an open floor the grid distance lies between the straight line and
/// GRID_OVERESTIMATE times it, up to the quantisation at both ends, and comes close to
/// that factor where a path climbs 2 cells in 5: it is not a lower bound there, which
/// is what the cost bound allows for.
#[test]
fn the_grid_distance_exceeds_the_straight_line_by_at_most_its_factor() {
    let g = GridMap::new_free(0.0, 0.0, 0.1, 12.0, 12.0).unwrap();
    let mut dm = DistanceMap::default();
    dm.ensure(&g.view());
    let goal = (1.05, 1.05);
    let mut h = GridHeuristic::default();
    assert!(h.begin(&dm, 0.2, 0.1, (goal, (11.05, 11.05)), true));
    let q = h.quantisation();
    let mut worst: f64 = 0.0;
    // Within 8 m a side: the diagonals' 1 % shortfall stays within the quantisation.
    for ix in 0..80 {
        for iy in 0..80 {
            let (x, y) = (1.05 + 0.1 * ix as f64, 1.05 + 0.1 * iy as f64);
            let line = (x - goal.0).hypot(y - goal.1);
            let grid = h.metres(&dm, x, y).unwrap();
            assert!(
                grid <= GRID_OVERESTIMATE * line + 1e-9,
                "({x}, {y}): {grid} > {line}"
            );
            assert!(grid + q >= line, "({x}, {y}): {grid} < {line}");
            if line > 5.0 {
                worst = worst.max(grid / line);
            }
        }
    }
    assert!(worst > 1.07, "{worst}");
}
