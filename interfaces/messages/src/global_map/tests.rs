use super::*;
use crate::{CellChangeMsg, MAX_MAP_CHANGES, zeroed_box};

fn full(version: u64, cells: &[u8]) -> Box<GlobalGrid> {
    let mut m = zeroed_box::<GlobalGrid>();
    (m.width, m.height, m.resolution) = (cells.len() as u32 / 2, 2, 0.1);
    m.version = version;
    m.cells[..cells.len()].copy_from_slice(cells);
    m
}

fn changes(base: u64, version: u64, list: &[(u64, u8)]) -> Box<MapChanges> {
    let mut m = zeroed_box::<MapChanges>();
    (m.base_version, m.version, m.width, m.height) = (base, version, 3, 2);
    m.len = list.len() as u32;
    for (e, &(index, value)) in m.changes.iter_mut().zip(list) {
        *e = CellChangeMsg {
            index,
            value,
            _pad: [0; 7],
        };
    }
    m
}

fn cells(g: &GlobalMapCopy) -> Vec<u8> {
    g.view().unwrap().cells.to_vec()
}

#[test]
fn the_newest_changes_alone_bring_the_full_map_to_their_version() {
    let mut g = GlobalMapCopy::with_capacity(6);
    // Changes before any full map wait for it.
    let c3 = changes(0, 3, &[(1, 2), (4, 2)]);
    assert_eq!(g.update(None, Some(&c3)), Ok(MapUpdate::default()));
    assert!(g.view().is_err() && g.base_version().is_none());
    let f0 = full(0, &[0, 0, 1, 0, 0, 0]);
    let u = g.update(Some(&f0), Some(&c3)).unwrap();
    assert!(u.full && u.changes == Some(2));
    assert_eq!((cells(&g), g.version()), (vec![0, 2, 1, 0, 2, 0], 3));
    // Version 4 skipped, 5 lists every cell since the full map: cell 1 cleared again.
    let c5 = changes(0, 5, &[(1, 0), (4, 2), (5, 2)]);
    assert_eq!(g.update(None, Some(&c5)).unwrap().changes, Some(3));
    assert_eq!((cells(&g), g.version()), (vec![0, 0, 1, 0, 2, 2], 5));
    // The same (or older) changes again change nothing.
    assert!(!g.update(None, Some(&c5)).unwrap().changed());
    assert!(!g.update(None, Some(&c3)).unwrap().changed());
    // A full map given again is taken whole, then the changes again.
    let u = g.update(Some(&f0), Some(&c5)).unwrap();
    assert!(u.full && u.changes == Some(3));
    assert_eq!(cells(&g), vec![0, 0, 1, 0, 2, 2]);
}

#[test]
fn a_new_full_map_replaces_the_copy_and_changes_of_the_old_one_are_left() {
    let mut g = GlobalMapCopy::default();
    g.update(Some(&full(0, &[0; 6])), Some(&changes(0, 2, &[(0, 2)])))
        .unwrap();
    let f7 = full(7, &[1, 0, 0, 0, 0, 2]);
    let u = g
        .update(Some(&f7), Some(&changes(0, 6, &[(0, 2)])))
        .unwrap();
    assert!(u.full && u.changes.is_none());
    assert_eq!(
        (cells(&g), g.version(), g.base_version()),
        (vec![1, 0, 0, 0, 0, 2], 7, Some(7))
    );
    g.update(None, Some(&changes(7, 8, &[(5, 0)]))).unwrap();
    assert_eq!((cells(&g), g.version()), (vec![1, 0, 0, 0, 0, 0], 8));
}

#[test]
fn a_mapper_started_afresh_counts_from_its_own_full_map_again() {
    let mut g = GlobalMapCopy::default();
    g.update(Some(&full(0, &[0; 6])), Some(&changes(0, 40, &[(0, 2)])))
        .unwrap();
    // Its static map at version 0 again, then its first change.
    g.update(Some(&full(0, &[0, 1, 0, 0, 0, 0])), None).unwrap();
    assert_eq!((cells(&g), g.version()), (vec![0, 1, 0, 0, 0, 0], 0));
    g.update(None, Some(&changes(0, 1, &[(2, 2)]))).unwrap();
    assert_eq!((cells(&g), g.version()), (vec![0, 1, 2, 0, 0, 0], 1));
}

#[test]
fn changes_that_do_not_fit_the_full_map_are_refused_whole() {
    let mut g = GlobalMapCopy::default();
    let f = full(1, &[0; 6]);
    g.update(Some(&f), None).unwrap();
    let bad_cell = changes(1, 2, &[(0, 2), (6, 2)]);
    assert_eq!(
        g.update(None, Some(&bad_cell)),
        Err(MapChangesError::Cell {
            entry: 1,
            index: 6,
            cells: 6
        })
    );
    assert_eq!((cells(&g), g.version()), (vec![0; 6], 1), "nothing written");
    let mut broken = full(5, &[1; 6]);
    broken.resolution = 0.0;
    let u = g.update(Some(&broken), None).unwrap();
    assert!(!u.full && u.refused.is_some());
    assert_eq!(
        (cells(&g), g.version()),
        (vec![0; 6], 1),
        "the held map stays"
    );
    let mut shape = changes(1, 2, &[(0, 2)]);
    shape.width = 2;
    assert!(matches!(
        g.update(None, Some(&shape)),
        Err(MapChangesError::Shape { .. })
    ));
    let mut many = changes(1, 2, &[]);
    many.len = MAX_MAP_CHANGES as u32 + 1;
    assert!(matches!(
        g.update(None, Some(&many)),
        Err(MapChangesError::TooMany { .. })
    ));
    g.update(None, Some(&changes(1, 2, &[(3, 2)]))).unwrap();
    assert_eq!(cells(&g), vec![0, 0, 0, 2, 0, 0]);
}
