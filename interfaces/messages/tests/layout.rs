//! Layout test: the size, alignment and field offsets of every message are pinned here,
//! so a change to any of them is a deliberate, reviewed change (and a new version).

use aisle_messages::*;

#[test]
fn every_message_has_a_versioned_unique_type_name() {
    let layouts = all_layouts();
    let mut names: Vec<_> = layouts.iter().map(|l| l.0).collect();
    for n in &names {
        assert!(
            n.starts_with("aisle.") && n.rsplit('.').next().unwrap().starts_with('v'),
            "{n}"
        );
    }
    names.sort();
    names.dedup();
    assert_eq!(names.len(), layouts.len(), "type names must be unique");
}

#[test]
fn fields_are_contiguous_and_inside_the_type() {
    for (name, size, align, fields) in all_layouts() {
        assert_eq!(align, 8, "{name}: every message is 8-byte aligned");
        let mut end = 0;
        for f in fields {
            assert!(
                f.offset >= end,
                "{name}.{} overlaps the previous field",
                f.name
            );
            assert!(
                f.offset - end < 8,
                "{name}.{}: hidden padding of {} bytes; make it an explicit _pad field",
                f.name,
                f.offset - end
            );
            end = f.offset + f.size;
        }
        assert_eq!(end, size, "{name}: trailing padding; make it explicit");
    }
}

#[test]
fn pinned_offsets_of_the_wire_header_and_large_payloads() {
    let off = |fields: &[FieldLayout], n: &str| fields.iter().find(|f| f.name == n).unwrap().offset;
    assert_eq!(off(Header::FIELDS, "stamp_ns"), 8);
    assert_eq!(off(Header::FIELDS, "source"), 40);
    assert_eq!(off(PointCloud::FIELDS, "points"), 136);
    assert_eq!(off(OccupancyGrid::FIELDS, "cells"), 96);
    assert_eq!(off(MapChanges::FIELDS, "changes"), 80);
    assert_eq!(core::mem::size_of::<CellChangeMsg>(), 16);
    assert_eq!(off(Trajectory::FIELDS, "commands"), 120);
    assert_eq!(off(ControllerGoal::FIELDS, "reference"), 160);
    assert_eq!(core::mem::size_of::<PointCloud>(), 1_573_000);
    const { assert!(MAX_CLOUD_POINTS >= 31 * 1201, "the seed's lidar must fit") };
}

#[test]
fn schema_hash_is_stable_within_a_build_and_sensitive_to_layout() {
    assert_eq!(schema_hash(), schema_hash());
    assert_eq!(schema_hash_hex().len(), 16);
    assert_ne!(schema_hash(), 0);
}

#[test]
fn wire_enums_decode_only_known_codes() {
    assert_eq!(PlanStatus::from_u32(3), Some(PlanStatus::NoPath));
    assert_eq!(PlanStatus::from_u32(99), None);
    assert_eq!(
        NodeKind::from_name("teb_controller"),
        Some(NodeKind::TebController)
    );
    for k in NodeKind::BUILT_IN {
        assert_eq!(NodeKind::from_u32(k.code()), Some(k));
        assert_eq!(NodeKind::from_name(k.name()), Some(k));
    }
}

#[test]
fn names_round_trip_and_truncate_on_char_boundaries() {
    let mut b = [0u8; 8];
    write_name(&mut b, "rack2b");
    assert_eq!(read_name(&b), "rack2b");
    write_name(&mut b, "ééééé"); // 10 bytes: cut to 8 at a boundary
    assert_eq!(read_name(&b), "éééé");
}
