//! Property tests: every parser of outside input (the TOML configs, the URDF, ROS map
//! YAML and PGM, MCAP records) is fed random bytes and mutations of the shipped files.
//! Each must answer with a value or an error, never a panic.

mod support;

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use support::config_dir;

/// A mutation of `text`: some bytes replaced, a tail cut, or a line duplicated.
fn mutated(text: &'static [u8]) -> impl Strategy<Value = Vec<u8>> {
    let n = text.len().max(1);
    (
        proptest::collection::vec((0..n, any::<u8>()), 0..8),
        0..=n,
        any::<bool>(),
    )
        .prop_map(move |(flips, cut, dup)| {
            let mut v = text.to_vec();
            for (i, b) in flips {
                if i < v.len() {
                    v[i] = b;
                }
            }
            v.truncate(cut.max(1));
            if dup && let Some(line) = v.split(|&c| c == b'\n').nth(2).map(<[u8]>::to_vec) {
                v.extend_from_slice(b"\n");
                v.extend_from_slice(&line);
            }
            v
        })
}

fn shipped(name: &str) -> &'static [u8] {
    Box::leak(
        std::fs::read(config_dir().join(name))
            .unwrap()
            .into_boxed_slice(),
    )
}

/// Writes `bytes` to a file named `name` (loaders that take a path) in a private
/// directory of its own, removed with the returned guard: cases run side by side.
fn scratch(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    (dir, p)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn config_parsers(name: &str, bytes: &[u8]) {
    let (_dir, p) = scratch(name, bytes);
    let scene = aisle_config::scene::Scene::load(&config_dir().join("warehouse.toml")).unwrap();
    match name {
        "warehouse.toml" => drop(aisle_config::scene::Scene::parse(
            Path::new(name),
            &text(bytes),
        )),
        "robot.toml" => drop(aisle_config::parse::<aisle_robot::RobotConfig>(
            Path::new(name),
            &text(bytes),
        )),
        "lidar.toml" => drop(aisle_config::parse::<aisle_robot::LidarConfig>(
            Path::new(name),
            &text(bytes),
        )),
        "mapper.toml" => drop(aisle_config::load::<aisle_mapper::MapConfig>(&p)),
        "planner.toml" => drop(aisle_config::load::<aisle_global_planner::PlannerConfig>(
            &p,
        )),
        "teb.toml" => drop(aisle_config::load::<aisle_teb_controller::TebConfig>(&p)),
        "mission.toml" => drop(aisle_supervisor::mission::MissionConfig::load(&p, &scene)),
        "budgets.toml" => drop(aisle_config::load::<aisle_tools::latency::Budgets>(&p)),
        "restart.toml" => drop(aisle_config::load::<aisle_supervisor::restart::RestartConfig>(&p)),
        "realtime.toml" => drop(
            aisle_node::realtime::RealtimeConfig::load_dir(
                p.parent().unwrap(),
                &aisle_node::Graph::shipped(),
            )
            .map(|c| c.check_cpus(&[0])),
        ),
        other => panic!("no parser for {other}"),
    }
}

const CONFIGS: [&str; 10] = [
    "warehouse.toml",
    "robot.toml",
    "lidar.toml",
    "mapper.toml",
    "planner.toml",
    "teb.toml",
    "mission.toml",
    "budgets.toml",
    "restart.toml",
    "realtime.toml",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn config_files_never_panic(
        (name, bytes) in (0..CONFIGS.len()).prop_flat_map(|i| (Just(CONFIGS[i]), mutated(shipped(CONFIGS[i]))))
    ) {
        config_parsers(name, &bytes);
    }

    #[test]
    fn configs_of_random_bytes_never_panic(which in 0..CONFIGS.len(), bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        config_parsers(CONFIGS[which], &bytes);
    }

    #[test]
    fn the_urdf_never_panics(bytes in mutated(shipped("jackal.urdf"))) {
        let cfg = aisle_robot::RobotConfig::default();
        let _ = aisle_robot::RobotModel::parse(Path::new("jackal.urdf"), &text(&bytes), &cfg);
    }

    #[test]
    fn ros_map_yaml_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
        let _ = aisle_mapper::ros_map::parse_map_yaml(Path::new("map.yaml"), &text(&bytes));
    }

    #[test]
    fn ros_map_yaml_mutations_never_panic(bytes in mutated(b"image: map.pgm\nresolution: 0.1\norigin: [-5.0, -10.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")) {
        let _ = aisle_mapper::ros_map::parse_map_yaml(Path::new("map.yaml"), &text(&bytes));
    }

    #[test]
    fn pgm_never_panics(bytes in mutated(b"P5\n# aisle\n4 3\n255\n\x00\x10\x20\x30\x40\x50\x60\x70\x80\x90\xa0\xb0")) {
        let _ = aisle_mapper::ros_map::parse_pgm(Path::new("map.pgm"), &bytes);
    }

    #[test]
    fn mcap_reader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        if let Ok(file) = aisle_tools::reader::RecordFile::from_bytes(Path::new("x.mcap"), bytes) {
            for m in file.messages().take(1000) {
                let _ = m;
            }
            let _ = file.metadata();
            let _ = file.attachments();
        }
    }
}
