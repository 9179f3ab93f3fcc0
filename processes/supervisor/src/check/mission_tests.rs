//! The mission checks end to end on the shipped config and variants of its scene: each
//! refusal names the mission file's key, the leg and the body or the map, and valid
//! missions (the seed, a free heading, a rack set down where another was picked up)
//! pass.

use super::testing::{Fixture, mission, seed_with};

const PARK: &str = "goal = [6.0, 8.0, 1.5707963267948966]";
const DROP: &str = "goal = [6.0, -7.0, 0.0]";

fn refused(f: &Fixture, text: &str, wanted: &[&str]) -> String {
    let e = f.check(text).unwrap_err();
    assert!(e.contains("mission.toml"), "{e}");
    for w in wanted {
        assert!(e.contains(w), "`{w}` not in: {e}");
    }
    e
}

/// Picks `first` from a free heading and sets it down at (6, -7); then does the same
/// with `second`, set down at `second_goal`.
fn two_racks(first: &str, second: &str, second_goal: &str) -> String {
    mission(&format!(
        "[[leg]]\nname = \"to {first}\"\napproach = \"{first}\"\n\n\
         [[leg]]\nname = \"carry {first}\"\ngoal = [6.0, -7.0, 0.0]\ncarry = \"{first}\"\n\n\
         [[leg]]\nname = \"to {second}\"\napproach = \"{second}\"\n\n\
         [[leg]]\nname = \"carry {second}\"\ngoal = {second_goal}\ncarry = \"{second}\"\n"
    ))
}

#[test]
fn the_seed_and_other_valid_missions_pass() {
    let f = Fixture::shipped("valid");
    f.check(&seed_with("", "")).unwrap();
    // A pick from a free heading, a drop at another heading, a park in the storage lane.
    f.check(&mission(
        "[[leg]]\nname = \"to pick\"\napproach = \"rack1b\"\n\n\
         [[leg]]\nname = \"carry\"\ngoal = [7.0, -1.0, 1.0]\ncarry = \"rack1b\"\n\n\
         [[leg]]\nname = \"park\"\ngoal = [3.0, 8.0, 0.0]\n",
    ))
    .unwrap();
    // rack2b is carried away first, so rack1b may be set down where it stood.
    f.check(&two_racks(
        "rack2b",
        "rack1b",
        "[2.0, 13.0, 1.5707963267948966]",
    ))
    .unwrap();
}

#[test]
fn a_goal_overlapping_a_static_body_names_the_leg_and_the_body() {
    let f = Fixture::shipped("static-goal");
    refused(
        &f,
        &seed_with(PARK, "goal = [4.3, 10.0, 0.0]"),
        &[
            "key `leg[3].goal`",
            "leg `park`",
            "robot.toml footprint.alone",
            "overlaps body `rack_row_2`",
        ],
    );
}

#[test]
fn a_goal_on_a_known_movable_body_is_refused() {
    let f = Fixture::shipped("movable-goal");
    refused(
        &f,
        &mission("[[leg]]\nname = \"onto the pallet\"\ngoal = [0.9, 4.5, 0.0]\n"),
        &[
            "key `leg[0].goal`",
            "leg `onto the pallet`",
            "overlaps body `pallet_leg1`",
        ],
    );
}

#[test]
fn an_approach_goal_lies_under_its_own_body_but_not_on_another() {
    // A box under rack2b: the approached rack is expected there, the box is not.
    let f = Fixture::with_scene(
        "approach-box",
        "pose = [7.0, 15.0, 0.2]",
        "pose = [2.0, 13.0, 0.2]",
    );
    refused(
        &f,
        &seed_with("", ""),
        &[
            "key `leg[0].goal`",
            "leg `to pick`",
            "overlaps body `box_5`",
        ],
    );
}

#[test]
fn a_carrying_footprint_overlapping_a_static_body_is_refused() {
    // The robot alone would fit beside table_1 (y <= -2.0); carrying, it does not.
    let f = Fixture::shipped("carrying-goal");
    let e = refused(
        &f,
        &seed_with(DROP, "goal = [5.0, -1.65, 0.0]"),
        &[
            "key `leg[2].goal`",
            "leg `carry to drop`",
            "robot.toml footprint.carrying",
            "overlaps body `table_1`",
        ],
    );
    assert!(!e.contains("footprint.alone"), "{e}");
}

#[test]
fn a_turn_in_place_needs_its_turning_circle_clear() {
    // Facing along rack_row_2 0.32 m from it the robot fits (its half-width and the
    // least margin, 0.315 m); turning, its corners reach in (0.333 m).
    let f = Fixture::shipped("turn");
    let legs = "[[leg]]\nname = \"beside the row\"\ngoal = [4.18, 10.0, 1.5707963267948966]\n\n\
                [[leg]]\nname = \"turn\"\ngoal = [4.18, 10.0, -1.5707963267948966]\nrotate = true\n";
    refused(
        &f,
        &mission(legs),
        &[
            "key `leg[1].goal`",
            "leg `turn` turns in place",
            "overlaps body `rack_row_2`",
        ],
    );
}

#[test]
fn a_free_heading_is_checked_by_position_only() {
    let legs = "[[leg]]\nname = \"under rack2a\"\napproach = \"rack2a\"\n";
    let row = "pose = [2.0, 16.5, 1.5707963267948966]";
    // 0.5 m from rack_row_2: some heading fits (every heading does, in fact).
    let f = Fixture::with_scene("free-ok", row, "pose = [4.0, 16.5, 1.5707963267948966]");
    f.check(&mission(legs)).unwrap();
    // 0.2 m from it: no heading fits.
    let f = Fixture::with_scene("free-bad", row, "pose = [4.3, 16.5, 1.5707963267948966]");
    refused(
        &f,
        &mission(legs),
        &[
            "key `leg[0].approach`",
            "whatever heading the planner chooses",
            "leg `under rack2a`",
            "overlaps body `rack_row_2`",
        ],
    );
}

#[test]
fn a_drop_onto_another_body_names_both() {
    let f = Fixture::shipped("drop-on-rack");
    refused(
        &f,
        &seed_with(DROP, "goal = [2.0, 16.5, 0.0]"),
        &[
            "key `leg[2].goal`",
            "leg `carry to drop` sets `rack2b` down at (2.000, 16.500, ",
            "overlaps body `rack2a`",
        ],
    );
    // Where rack2b still stands, with every heading the free pick allows.
    refused(
        &f,
        &two_racks("rack1b", "rack2a", "[2.0, 13.0, 1.5707963267948966]"),
        &[
            "key `leg[3].goal`",
            "leg `carry rack2a` sets `rack2a` down",
            "in every heading it may have",
            "overlaps body `rack2b`",
        ],
    );
}

#[test]
fn a_drop_beside_another_body_keeps_the_carrying_margin_clear() {
    let f = Fixture::shipped("drop-beside");
    // Set down facing west (the seed's pick turns it): 0.88 m along x. 1 cm east of
    // pallet_leg3 (1.2 m long at x = 6.3), then 5 and 12 cm: all within the 0.15 m the
    // least carrying margin keeps; 0.2 m away is a drop.
    for gap in [0.01, 0.05, 0.12] {
        let x = 6.3 + 0.6 + gap + 0.44;
        refused(
            &f,
            &seed_with(DROP, &format!("goal = [{x}, 2.5, 0.0]")),
            &[
                "key `leg[2].goal`",
                "sets `rack2b` down",
                "body `pallet_leg3`",
                "within 0.15 m",
                "footprint.carrying",
            ],
        );
    }
    f.check(&seed_with(DROP, "goal = [7.54, 2.5, 0.0]"))
        .unwrap();
}

#[test]
fn a_drop_off_the_map_is_refused() {
    // No west wall: the robot fits at the map's edge, the rack it carries does not.
    let f = Fixture::with_scene(
        "drop-off-map",
        "pose = [-4.9, 5.0, 0.0]\nsize = [0.2, 29.6, 3.0]",
        "pose = [-4.9, 19.0, 0.0]\nsize = [0.2, 1.6, 3.0]",
    );
    refused(
        &f,
        &seed_with(DROP, "goal = [-4.7, 0.0, 0.0]"),
        &["key `leg[2].goal`", "sets `rack2b` down", "leaves the map"],
    );
}

/// A closed room of static walls around (6, -7), 2 m inside.
const ROOM: &str = "
[[body]]
name = \"room_south\"
kind = \"wall\"
static = true
pose = [6.0, -8.1, 0.0]
size = [2.4, 0.2, 1.0]

[[body]]
name = \"room_north\"
kind = \"wall\"
static = true
pose = [6.0, -5.9, 0.0]
size = [2.4, 0.2, 1.0]

[[body]]
name = \"room_west\"
kind = \"wall\"
static = true
pose = [4.9, -7.0, 0.0]
size = [0.2, 2.4, 1.0]

[[body]]
name = \"room_east\"
kind = \"wall\"
static = true
pose = [7.1, -7.0, 0.0]
size = [0.2, 2.4, 1.0]

# ---- Movable: pallet racks";

#[test]
fn a_goal_in_a_closed_room_is_unreachable_on_the_static_map() {
    let f = Fixture::with_scene("room", "# ---- Movable: pallet racks", ROOM);
    refused(
        &f,
        &seed_with("", ""),
        &[
            "key `leg[2].goal`",
            "the goal (6, -7) of leg `carry to drop` is unreachable on the static map",
            "mapper.toml",
            "no passage wide enough for the robot's footprint (robot.toml footprint.carrying",
            "connects it to (2, 13)",
        ],
    );
    refused(
        &f,
        &mission("[[leg]]\nname = \"into the room\"\ngoal = [6.0, -7.0, 0.0]\n"),
        &[
            "key `leg[0].goal`",
            "footprint.alone",
            "connects it to (0, 0)",
        ],
    );
}

#[test]
fn a_goal_in_the_maps_boundary_band_is_unreachable() {
    // Clear of the south wall (y <= -9.8), inside the 1 m band the planner never enters.
    let f = Fixture::shipped("band");
    refused(
        &f,
        &mission("[[leg]]\nname = \"by the wall\"\ngoal = [0.0, -9.3, 0.0]\n"),
        &[
            "key `leg[0].goal`",
            "leg `by the wall` is unreachable on the static map",
            "touches occupied cells",
        ],
    );
}

#[test]
fn a_carry_leg_must_start_under_its_body() {
    let f = Fixture::shipped("not-under");
    refused(
        &f,
        &mission("[[leg]]\nname = \"grab\"\ngoal = [3.0, 5.0, 0.0]\ncarry = \"rack2b\"\n"),
        &[
            "key `leg[0].carry`",
            "leg `grab` picks up `rack2b` where it starts, at (0, 0)",
            "approach it on the leg before",
        ],
    );
}

#[test]
fn a_turn_in_place_ends_where_it_starts() {
    let f = Fixture::shipped("rotate-away");
    refused(
        &f,
        &mission(
            "[[leg]]\nname = \"out\"\ngoal = [6.0, 5.0, 0.0]\n\
             [[leg]]\nname = \"turn elsewhere\"\ngoal = [7.0, 6.0, 1.57]\nrotate = true\n",
        ),
        &[
            "key `leg[1].goal`",
            "leg `turn elsewhere` turns in place, but its goal (7, 6) is 1.414 m from where it starts (6, 5)",
        ],
    );
}

#[test]
fn an_approach_with_a_goal_ends_under_the_body() {
    let f = Fixture::shipped("approach-beside");
    refused(
        &f,
        &mission("[[leg]]\nname = \"to pick\"\ngoal = [6.0, 5.0, 0.0]\napproach = \"rack2b\"\n"),
        &[
            "key `leg[0].goal`",
            "leg `to pick` approaches `rack2b`, but its goal (6, 5) leaves the carry mount",
            "`rack2b` stands at (2.000, 13.000)",
        ],
    );
}

#[test]
fn an_approach_without_a_goal_finds_the_body_where_the_mission_set_it_down() {
    // Picked at (2, 13), set down at (6, -7), then approached again and carried on: the
    // second pick starts under the rack where it stands, not where the scene had it.
    let f = Fixture::shipped("repick");
    f.check(&mission(
        "[[leg]]\nname = \"to pick\"\napproach = \"rack2b\"\n\
             [[leg]]\nname = \"carry\"\ngoal = [6.0, -7.0, 0.0]\ncarry = \"rack2b\"\n\
             [[leg]]\nname = \"away\"\ngoal = [6.0, 6.0, 1.57]\n\
             [[leg]]\nname = \"again\"\napproach = \"rack2b\"\n\
             [[leg]]\nname = \"carry on\"\ngoal = [8.0, 7.0, 1.57]\ncarry = \"rack2b\"\n",
    ))
    .unwrap();
}

#[test]
fn a_start_in_the_maps_boundary_band_is_refused() {
    // Inside the map and clear of every body, but in the 1 m band along its east edge.
    let f = Fixture::shipped("start-band");
    refused(
        &f,
        &seed_with("start = [0.0, 0.0, 0.0]", "start = [14.3, 5.0, 0.0]"),
        &[
            "key `start`",
            "at (14.3, 5, 0) touches occupied cells of the static map",
        ],
    );
}

#[test]
fn a_stated_heading_that_puts_the_robot_in_the_band_is_refused() {
    // 0.33 m from the east band (x >= 14): across, the robot's half-width and the least
    // margin fit (0.315 m); along, its half-length does not (0.354 m).
    let f = Fixture::shipped("band-heading");
    refused(
        &f,
        &mission("[[leg]]\nname = \"by the wall\"\ngoal = [13.67, 2.0, 0.0]\n"),
        &[
            "key `leg[0].goal`",
            "at the goal (13.67, 2, 0) of leg `by the wall`",
            "touches occupied cells of the static map",
        ],
    );
    f.check(&mission(
        "[[leg]]\nname = \"by the wall\"\ngoal = [13.67, 2.0, 1.5707963267948966]\n",
    ))
    .unwrap();
}

#[test]
fn a_carry_goal_that_puts_the_carried_rack_in_the_band_is_refused() {
    // 0.5 m from the east band (x >= 14): the rack's half-length (0.44 m) and the least
    // carrying margin (0.1 m) do not fit; 0.6 m from it they do.
    let f = Fixture::shipped("carry-band");
    refused(
        &f,
        &seed_with(DROP, "goal = [13.5, -7.0, 0.0]"),
        &[
            "key `leg[2].goal`",
            "leg `carry to drop`",
            "footprint.carrying grown to the carried body",
            "touches occupied cells of the static map",
        ],
    );
    f.check(&seed_with(DROP, "goal = [13.4, -7.0, 0.0]"))
        .unwrap();
}

#[test]
fn a_planner_timeout_a_request_cannot_carry_is_refused() {
    // The request holds whole milliseconds in 32 bits: 4294967.297 s was sent as 1 ms.
    let f = Fixture::shipped("timeout");
    for bad in ["4294967.297", "0.0001", "0.0"] {
        refused(
            &f,
            &seed_with(
                "planner_timeout_s = 5.0",
                &format!("planner_timeout_s = {bad}"),
            ),
            &["planner_timeout_s", "0.001..=3600"],
        );
    }
}
