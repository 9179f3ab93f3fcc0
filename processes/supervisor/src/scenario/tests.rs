//! The generator: the same seed gives the same bytes, every family passes `aisle check`,
//! and the poses it samples are free.

use super::geom::Rect;
use super::ground::{ALONE_CLEARANCE, Ground};
use super::*;
use crate::mission::MissionConfig;
use aisle_config::scene::Scene;

fn base() -> PathBuf {
    aisle_config::testing::shipped_dir()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aisle-scenario-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn make(g: &Ground, family: Family, seed: u64, out: &Path) -> Generated {
    let opts = GenerateOptions {
        seed,
        family,
        out: out.to_path_buf(),
        base: base(),
    };
    generate_from(g, &opts).unwrap()
}

fn text(dir: &Path, file: &str) -> String {
    std::fs::read_to_string(dir.join(file)).unwrap()
}

#[test]
fn the_same_seed_gives_the_same_bytes_and_another_seed_others() {
    let g = Ground::load(&base()).unwrap();
    let (a, b, c) = (scratch("a"), scratch("b"), scratch("c"));
    for family in Family::ALL {
        make(&g, family, 7, &a);
        make(&g, family, 7, &b);
        make(&g, family, 8, &c);
        for f in ["warehouse.toml", "mission.toml"] {
            assert_eq!(text(&a, f), text(&b, f), "{} {f}", family.name());
        }
        let differs = ["warehouse.toml", "mission.toml"]
            .iter()
            .any(|f| text(&a, f) != text(&c, f));
        assert!(differs, "{}: seeds 7 and 8 alike", family.name());
        assert!(text(&a, "mission.toml").contains(&format!("--family {}", family.name())));
    }
    for d in [a, b, c] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn every_family_passes_check() {
    let g = Ground::load(&base()).unwrap();
    let out = scratch("check");
    for family in Family::ALL {
        for seed in 1..=4 {
            let made = make(&g, family, seed, &out);
            assert!(!made.varied.is_empty(), "{} {seed}", family.name());
            crate::check::check_dir(&out).unwrap();
        }
    }
    let _ = std::fs::remove_dir_all(out);
}

/// The scene and mission of a generated directory.
fn load(dir: &Path) -> (Scene, MissionConfig) {
    let scene = Scene::load(&dir.join("warehouse.toml")).unwrap();
    let mission = MissionConfig::load(&dir.join("mission.toml"), &scene).unwrap();
    (scene, mission)
}

fn free_of(scene: &Scene, r: &Rect, except: &str) -> bool {
    scene
        .bodies
        .iter()
        .filter(|b| b.name != except)
        .all(|b| !Rect::new(b.pose, b.footprint()).overlaps(r))
}

#[test]
fn sampled_poses_are_free_with_their_clearance() {
    let g = Ground::load(&base()).unwrap();
    let out = scratch("free");
    let mut two_racks = 0;
    for seed in 1..=9 {
        make(&g, Family::Start, seed, &out);
        let (scene, mission) = load(&out);
        let r = g.robot_rect(mission.start_pose(), ALONE_CLEARANCE);
        assert!(
            r.inside(g.interior) && free_of(&scene, &r, ""),
            "start {seed}"
        );

        make(&g, Family::Mission, seed, &out);
        let (scene, mission) = load(&out);
        assert!(mission.leg.iter().all(|l| l.depart.is_none()));
        let mut drops: Vec<Rect> = Vec::new();
        for carry in mission.leg.iter().filter(|l| l.carry.is_some()) {
            let rack = carry.carry.as_deref().unwrap();
            assert_eq!(scene.body(rack).unwrap().1.kind, "pallet_rack");
            let [x, y, h] = carry.goal;
            let drop = g.carried_rect(aisle_geometry::Pose2::new(x, y, h), 0.0);
            assert!(
                drop.inside(g.interior) && free_of(&scene, &drop, rack),
                "drop {seed}"
            );
            assert!(drops.iter().all(|d| !d.overlaps(&drop)), "drops {seed}");
            drops.push(drop);
        }
        two_racks += usize::from(drops.len() == 2);
        let [x, y, h] = mission.leg.last().unwrap().goal;
        let park = g.robot_rect(aisle_geometry::Pose2::new(x, y, h), ALONE_CLEARANCE);
        assert!(
            park.inside(g.interior) && free_of(&scene, &park, ""),
            "park {seed}"
        );
        assert!(
            drops.iter().all(|d| !d.overlaps(&park)),
            "park {seed} clear of the dropped racks"
        );
    }
    assert!(two_racks > 0, "some missions carry two racks");
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn the_oracle_makes_every_unnamed_movable_body_static() {
    let g = Ground::load(&base()).unwrap();
    let (dir, oracle) = (scratch("o-src"), scratch("o"));
    make(&g, Family::Extra, 3, &dir);
    let fixed = write::write_oracle(&dir, &oracle).unwrap();
    let (scene, mission) = load(&oracle);
    let named: Vec<_> = mission.leg.iter().filter_map(|l| l.carry.clone()).collect();
    assert!(fixed.iter().any(|n| n.starts_with("extra_")), "{fixed:?}");
    for b in &scene.bodies {
        assert_eq!(
            !b.is_static,
            named.contains(&b.name)
                || mission
                    .leg
                    .iter()
                    .any(|l| l.approach.as_deref() == Some(&b.name)),
            "{}",
            b.name
        );
    }
    crate::check::check_dir(&oracle).unwrap();
    for d in [dir, oracle] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// A scene the base mission does not fit (one `aisle scene generate` wrote, the map
/// resized to it): the `mission` family draws a start and a mission of its own that
/// pass `check`; the families that vary the base mission are refused, naming why.
#[test]
fn a_new_scene_gets_missions_of_its_own() {
    use aisle_config::scene_gen::{GenParams, generate};
    let new_base = scratch("new-scene-base");
    write::copy_tree(&base(), &new_base).unwrap();
    let mut params = GenParams::new(3, 45.0, 5);
    params.aisle_width = 2.6;
    params.cross_every = 15.0;
    std::fs::write(new_base.join("warehouse.toml"), generate(&params)).unwrap();
    // 14.8 x 72.4 m: the map `aisle scene generate` proposes for it.
    let mapper = text(&new_base, "mapper.toml");
    let resized = mapper
        .replace("origin = [-5.0, -10.0]", "origin = [-1.0, -1.0]")
        .replace("size = [20.0, 30.0]", "size = [16.8, 74.4]");
    assert_ne!(resized, mapper, "the shipped map's lines");
    std::fs::write(new_base.join("mapper.toml"), resized).unwrap();

    let g = Ground::load(&new_base).unwrap();
    let unfit = g
        .mission_unfit
        .clone()
        .expect("the seed mission names seed racks");
    let out = scratch("new-scene");
    for seed in 1..=3 {
        let opts = GenerateOptions {
            seed,
            family: Family::Mission,
            out: out.clone(),
            base: new_base.clone(),
        };
        let made = generate_from(&g, &opts).unwrap();
        assert!(
            made.varied.iter().any(|v| v.starts_with("start")),
            "{:?}",
            made.varied
        );
        crate::check::check_dir(&out).unwrap();
    }
    let opts = GenerateOptions {
        seed: 1,
        family: Family::Moved,
        out: out.clone(),
        base: new_base.clone(),
    };
    let e = generate_from(&g, &opts).unwrap_err();
    assert!(e.contains(&unfit) && e.contains("--family mission"), "{e}");
    let _ = std::fs::remove_dir_all(out);
    let _ = std::fs::remove_dir_all(new_base);
}

/// A record kept beside the base config is not copied into scenarios (nor, through
/// `copy_tree`, into oracles).
#[test]
fn a_record_beside_the_base_is_not_copied() {
    let with_record = scratch("base-with-record");
    write::copy_tree(&base(), &with_record).unwrap();
    std::fs::write(with_record.join("run.mcap"), "not config").unwrap();
    let out = scratch("copied-without-record");
    write::copy_tree(&with_record, &out).unwrap();
    assert!(out.join("mission.toml").is_file());
    assert!(!out.join("run.mcap").exists());
    for d in [with_record, out] {
        let _ = std::fs::remove_dir_all(d);
    }
}
