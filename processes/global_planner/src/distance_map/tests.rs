use super::*;
use crate::tests::stream;
use aisle_geometry::{CellIndex, FREE, GridMap, OCCUPIED_STATIC};

#[test]
fn matches_brute_force() {
    let mut g = GridMap::new_free(0.0, 0.0, 0.1, 2.3, 1.7).unwrap();
    for (ix, iy) in [(3, 4), (10, 2), (11, 2), (20, 15), (7, 9)] {
        g.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
    }
    let v = g.view();
    for lazy in [false, true] {
        let mut dm = DistanceMap {
            force_lazy: lazy,
            ..DistanceMap::default()
        };
        assert!(dm.ensure(&v));
        assert!(!dm.ensure(&v), "same map is not rebuilt");
        for iy in 0..v.height as i64 {
            for ix in 0..v.width as i64 {
                let mut best = f64::INFINITY;
                for oy in -1..=v.height as i64 {
                    for ox in -1..=v.width as i64 {
                        let c = CellIndex { ix: ox, iy: oy };
                        if v.occupied_or_outside(c) {
                            best = best.min(((ox - ix) as f64).hypot((oy - iy) as f64));
                        }
                    }
                }
                let got = f64::from(dm.dist_at(ix as usize, iy as usize));
                assert!(
                    (got - (best * 0.1).min(DIST_CAP)).abs() < 1e-5,
                    "({ix},{iy}) {got} vs {best}"
                );
            }
        }
        assert!(dm.occupied_in_row(2, 0, v.width - 1));
        assert!(dm.occupied_in_row(2, 11, 11));
        assert!(!dm.occupied_in_row(2, 12, 22));
    }
    let mut dm = DistanceMap::default();
    dm.ensure(&g.view());
    g.set(CellIndex { ix: 0, iy: 0 }, OCCUPIED_STATIC);
    assert!(dm.ensure(&g.view()), "a changed cell is noticed");
}

/// Every cell of `dm`, read tile by tile in a shuffled order, against a whole-grid
/// transform of `v`, bit for bit.
fn assert_equals_whole_grid(dm: &DistanceMap, v: &GridView, next: &mut impl FnMut(i64) -> i64) {
    let whole = dist_tiles::whole_grid(
        Cells {
            cells: v.cells,
            w: v.width,
            h: v.height,
        },
        v.resolution,
        DIST_CAP,
    );
    let mut order: Vec<usize> = (0..v.width * v.height).collect();
    for i in (1..order.len()).rev() {
        order.swap(i, next(i as i64 + 1) as usize);
    }
    for i in order {
        let (x, y) = (i % v.width, i / v.width);
        assert_eq!(
            dm.dist_at(x, y).to_bits(),
            whole[i].to_bits(),
            "cell ({x}, {y}): {} vs {}",
            dm.dist_at(x, y),
            whole[i]
        );
    }
}

/// Tiles computed lazily, and again after a sequence of changes, are bit for bit those
/// of a whole-grid transform of the current cells.
#[test]
fn lazy_tiles_equal_a_full_rebuild_bit_for_bit() {
    let mut next = stream(0x2545_f491_4f6c_dd1d);
    // Sizes that are not whole tiles, at two resolutions (the cap is 81 and 161 cells).
    for (res, wm, hm) in [(0.1, 43.3, 27.9), (0.05, 19.7, 33.1)] {
        let mut g = GridMap::new_free(-3.0, 2.0, res, wm, hm).unwrap();
        let (w, h) = (g.view().width as i64, g.view().height as i64);
        for _ in 0..300 {
            let (ix, iy) = (next(w), next(h));
            g.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
        }
        // A few racks: long runs, where the envelope has many parabolas (across), and
        // where the vertical pass meets many columns in one row (along).
        for r in 0..12 {
            let (x0, y0, len) = (next(w), next(h), 20 + next(200));
            for k in 0..len {
                let c = if r % 3 == 2 {
                    CellIndex { ix: x0, iy: y0 + k }
                } else {
                    CellIndex { ix: x0 + k, iy: y0 }
                };
                g.set(c, OCCUPIED_STATIC);
            }
        }
        let mut kept = DistanceMap {
            force_lazy: true,
            ..DistanceMap::default()
        };
        kept.ensure(&g.view());
        assert_equals_whole_grid(&kept, &g.view(), &mut next);
        let full_cells = kept.last_recomputed;
        let mut partial = 0;
        for round in 0..10 {
            // A small cluster appears (or goes) somewhere, corners and edges included.
            let (cx, cy) = match round {
                0 => (0, 0),
                1 => (w - 1, h - 1),
                2 => (0, h / 2),
                _ => (next(w), next(h)),
            };
            let value = if round % 3 == 2 {
                FREE
            } else {
                OCCUPIED_STATIC
            };
            for k in 0..6 {
                let c = CellIndex {
                    ix: (cx + k % 3).min(w - 1),
                    iy: (cy + k / 3).min(h - 1),
                };
                g.set(c, value);
            }
            // Some tiles read before the change, some not.
            for _ in 0..20 {
                kept.dist_at(next(w) as usize, next(h) as usize);
            }
            kept.ensure(&g.view());
            partial += usize::from(kept.last_recomputed < full_cells);
            assert_equals_whole_grid(&kept, &g.view(), &mut next);
        }
        assert!(partial >= 5, "only {partial} of 10 changes were partial");
    }
}

/// On a large map only the tiles read are computed, and a change drops only the tiles
/// within the cap of it.
#[test]
fn only_tiles_read_are_computed() {
    let mut g = GridMap::new_free(0.0, 0.0, 0.05, 100.0, 60.0).unwrap();
    g.set(CellIndex { ix: 100, iy: 100 }, OCCUPIED_STATIC);
    let mut dm = DistanceMap::default();
    dm.ensure(&g.view());
    assert!(g.view().width * g.view().height > EAGER_CELLS);
    assert_eq!(dm.tiles_computed.get(), 0);
    assert_eq!(f64::from(dm.dist_at(100, 103)), 0.15000000596046448);
    assert_eq!(dm.tiles_computed.get(), 1);
    dm.dist_at(101, 90);
    assert_eq!(dm.tiles_computed.get(), 1, "same tile");
    g.set(CellIndex { ix: 1900, iy: 1100 }, OCCUPIED_STATIC);
    assert!(dm.ensure(&g.view()));
    dm.dist_at(100, 103);
    assert_eq!(
        dm.tiles_computed.get(),
        1,
        "a change 80 m away keeps the tile"
    );
    g.set(CellIndex { ix: 120, iy: 100 }, OCCUPIED_STATIC);
    assert!(dm.ensure(&g.view()));
    assert_eq!(f64::from(dm.dist_at(120, 101)), 0.05000000074505806);
    assert_eq!(
        dm.tiles_computed.get(),
        2,
        "the tile near the change is computed again"
    );
    let gen0 = dm.generation;
    g.set(CellIndex { ix: 500, iy: 500 }, OCCUPIED_STATIC);
    dm.ensure(&g.view());
    let changed: Vec<Window> = dm.changes_since(gen0).unwrap().collect();
    assert_eq!(changed.len(), 1);
    assert!(changed[0].x0 < 500 && changed[0].x1 > 500);
    assert!(dm.changes_since(0).is_none(), "before the rebuild: unknown");
}

#[test]
fn occupancy_words_match_a_plain_loop() {
    let mut next = stream(0x9e37_79b9_7f4a_7c15);
    for len in 0..=64 {
        for _ in 0..20 {
            let row: Vec<u8> = (0..len)
                .map(|_| [FREE, FREE, FREE, 1, 2, 127, 128, 255][next(8) as usize])
                .collect();
            let plain = row
                .iter()
                .enumerate()
                .fold(0u64, |w, (x, &c)| w | (u64::from(c != FREE) << x));
            assert_eq!(dist_tiles::occupancy_word(&row), plain, "{row:?}");
        }
    }
}
