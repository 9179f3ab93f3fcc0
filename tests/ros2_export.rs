//! `aisle export --ros2` read back by an independent reader: a short lockstep mission is
//! recorded, exported, and `tests/ros2_export.py` (the `rosbags` package, AnyReader over
//! the `.mcap`) deserializes every message of the bag and compares points, poses, paths,
//! commands and grids with the source record, which this test decodes with the
//! project's own reader into `expected.json` (and the clouds' and grids' bulk into two
//! binary files). Skips, saying why, when `rosbags` is not installed, unless
//! `AISLE_REQUIRE_PYTHON_SDK=1` (as `.ci/run` sets it: there it fails). Also: bad input
//! (missing, not MCAP, not a record, truncated, output = input, output not writable) ends
//! in exit 2.

mod support;

use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, ControllerGoal, GlobalGrid, GlobalMapCopy, GridMessage, MapChanges,
    OccupancyGrid, PointCloud, RobotState, Trajectory,
};
use aisle_tools::RecordFile;
use aisle_tools::aligned::AlignedBuf;
use serde_json::{Value, json};
use std::io::Write;
use std::path::Path;
use std::process::Command;
use support::{TestDir, mission_file};

fn rosbags_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import rosbags.highlevel, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        let why = "python3 with the `rosbags` package is not available \
                   (pip install rosbags)";
        if std::env::var("AISLE_REQUIRE_PYTHON_SDK").as_deref() == Ok("1") {
            panic!("{why} (AISLE_REQUIRE_PYTHON_SDK=1)");
        }
        eprintln!("\n*** SKIPPED ros2_export: {why} ***\n");
    }
    ok
}

#[test]
fn rosbags_reads_every_message_and_matches_the_record() {
    if !rosbags_available() {
        return;
    }
    let dir = TestDir::new("ros2");
    let mission = mission_file(
        &dir,
        "short.toml",
        "[[leg]]\nname = \"short hop\"\ngoal = [3.0, -2.0, 0.0]\n",
    );
    let config = support::config_dir();
    let (_, record, _) = support::run_recorded(
        &dir,
        &config,
        "run",
        &["--mission", mission.to_str().unwrap()],
    );
    let bag = dir.path("run.ros2.mcap");
    let out = support::run(
        &dir.run_dir(),
        &[
            "export",
            "--ros2",
            record.to_str().unwrap(),
            bag.to_str().unwrap(),
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let expected = write_expected(&record, &dir);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/ros2_export.py");
    let py = Command::new("python3")
        .arg(&script)
        .arg(&bag)
        .arg(&expected)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&py.stdout);
    assert!(
        py.status.success(),
        "{report}\n{}",
        String::from_utf8_lossy(&py.stderr)
    );
    let v: Value = serde_json::from_str(report.lines().last().unwrap_or("")).unwrap();
    assert_eq!(v["problems"], json!([]), "{report}");
    // Every message the export says it wrote was deserialized, topic by topic.
    for line in stdout.lines().skip(1) {
        let mut it = line.split_whitespace();
        let (topic, n) = (it.next().unwrap(), it.next().unwrap());
        assert_eq!(v["decoded"][topic].to_string(), n, "{topic}: {report}");
    }
    assert!(
        v["decoded"]["/aisle/points"].as_u64().unwrap() > 10,
        "{report}"
    );
}

/// A grid's JSON entry; its cells go at `cell_at` of `grids.bin`.
fn grid_entry(g: &aisle_geometry::GridView<'_>, stamp: u64, cell_at: &mut usize) -> Value {
    let entry = json!({"stamp": stamp, "width": g.width,
        "height": g.height, "resolution": g.resolution,
        "origin": [g.origin_x, g.origin_y], "offset": *cell_at});
    *cell_at += g.cells.len();
    entry
}

/// The source record decoded with the project's reader: JSON for the small messages,
/// `points.bin` (every cloud's xyz as little-endian f32, NaN kept) and `grids.bin`
/// (every grid's cells, aisle's 0/1/2) for the bulk. Returns the JSON's path.
fn write_expected(record: &Path, dir: &TestDir) -> std::path::PathBuf {
    let file = RecordFile::open(record).unwrap();
    let mut points =
        std::io::BufWriter::new(std::fs::File::create(dir.path("points.bin")).unwrap());
    let mut grids = std::io::BufWriter::new(std::fs::File::create(dir.path("grids.bin")).unwrap());
    let (mut robot, mut clouds, mut global, mut local) = (vec![], vec![], vec![], vec![]);
    let (mut plans, mut bands, mut cmds) = (vec![], vec![], vec![]);
    let (mut point_at, mut cell_at, mut last_goal) = (0usize, 0usize, None);
    let mut buf = AlignedBuf::new();
    let mut held = GlobalMapCopy::default();
    for m in file.raw_messages() {
        let m = m.unwrap();
        buf.set(&m.data);
        match m.channel.topic.as_str() {
            s::ROBOT_STATE => {
                let r = buf.view::<RobotState>().unwrap();
                let p = &r.pose;
                robot.push(json!([
                    r.header.stamp_ns,
                    p.x,
                    p.y,
                    p.theta,
                    r.twist[0],
                    r.twist[1]
                ]));
            }
            s::POINT_CLOUD => {
                let c = buf.view::<PointCloud>().unwrap();
                let n = (c.rows * c.cols) as usize;
                for v in c.points[..n].iter().flatten() {
                    points.write_all(&v.to_le_bytes()).unwrap();
                }
                let (sp, rp) = (&c.sensor_pose, &c.robot_pose);
                clouds.push(
                    json!({"stamp": c.header.stamp_ns, "rows": c.rows, "cols": c.cols,
                    "offset": point_at, "sensor": sp.position, "robot": [rp.x, rp.y, rp.theta]}),
                );
                point_at += n;
            }
            s::LOCAL_MAP => {
                let g = buf.view::<OccupancyGrid>().unwrap();
                let view = g.view().unwrap();
                local.push(grid_entry(&view, g.header.stamp_ns, &mut cell_at));
                grids.write_all(view.cells).unwrap();
            }
            // `/map` is every version of the global map: a full map and its changes.
            t @ (s::GLOBAL_MAP | s::GLOBAL_MAP_CHANGES) => {
                let (stamp, update) = if t == s::GLOBAL_MAP {
                    let g = buf.view::<GlobalGrid>().unwrap();
                    (g.header.stamp_ns, held.update(Some(g), None))
                } else {
                    let c = buf.view::<MapChanges>().unwrap();
                    (c.header.stamp_ns, held.update(None, Some(c)))
                };
                if update.unwrap().changed() {
                    let view = held.view().unwrap();
                    global.push(grid_entry(&view, stamp, &mut cell_at));
                    grids.write_all(view.cells).unwrap();
                }
            }
            s::CONTROLLER_GOAL => {
                let g = buf.view::<ControllerGoal>().unwrap();
                if last_goal != Some(g.goal_id) {
                    last_goal = Some(g.goal_id);
                    let poses: Vec<_> = g.reference[..g.len as usize]
                        .iter()
                        .map(|p| [p.x, p.y, p.theta])
                        .collect();
                    plans.push(json!({"stamp": g.header.stamp_ns, "poses": poses}));
                }
            }
            s::CONTROLLER_BAND => {
                let b = buf.view::<ControllerBand>().unwrap();
                let poses: Vec<_> = b.poses[..b.len as usize]
                    .iter()
                    .map(|p| [p.t, p.x, p.y, p.theta])
                    .collect();
                bands.push(json!({"stamp": b.header.stamp_ns, "poses": poses}));
            }
            s::TRAJECTORY => {
                let t = buf.view::<Trajectory>().unwrap();
                let c = t.commands[..t.len as usize]
                    .first()
                    .map_or((0.0, 0.0), |c| (c.v, c.w));
                cmds.push(json!([t.header.stamp_ns, c.0, c.1]));
            }
            _ => {}
        }
    }
    points.flush().unwrap();
    grids.flush().unwrap();
    let expected = json!({
        "robot": robot, "clouds": clouds, "global": global, "local": local,
        "plans": plans, "bands": bands, "cmds": cmds,
        "driven_every": aisle_tools::ros2::DRIVEN_EVERY,
        "points": dir.path("points.bin"), "grids": dir.path("grids.bin"),
    });
    let path = dir.path("expected.json");
    std::fs::write(&path, expected.to_string()).unwrap();
    path
}

/// Bad input ends in exit 2 and one line naming the file, and leaves no output behind.
#[test]
fn export_refuses_what_it_cannot_convert() {
    let dir = TestDir::new("ros2-bad");
    let record = dir.path("synthetic.mcap");
    let f = std::fs::File::create(&record).unwrap();
    aisle_tools::synthetic::write_synthetic(f, 10, aisle_tools::WriterOptions::default()).unwrap();
    let bag = dir.path("bag.mcap");
    let ok = support::run(&dir.run_dir(), &["export", "--ros2", p(&record), p(&bag)]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let text = dir.path("notes.txt");
    std::fs::write(&text, "not an mcap").unwrap();
    // A record cut short (a recorder killed mid-write, a copy interrupted): bad input.
    let bytes = std::fs::read(&record).unwrap();
    let truncated = dir.path("truncated.mcap");
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let cases: [(&Path, &Path, &str); 6] = [
        (&truncated, &dir.path("t.mcap"), "truncated.mcap"),
        (
            &dir.path("missing.mcap"),
            &dir.path("o.mcap"),
            "missing.mcap",
        ),
        (&text, &dir.path("o.mcap"), "is not an MCAP file"),
        (&bag, &dir.path("o.mcap"), "is not an aisle record"),
        (&record, &record, "is the record itself"),
        (&record, &dir.path("no/such/dir/o.mcap"), "cannot write"),
    ];
    for (input, output, says) in cases {
        let out = support::run(&dir.run_dir(), &["export", "--ros2", p(input), p(output)]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{input:?} -> {output:?}: {err}");
        assert!(
            err.starts_with("error: ") && err.contains(says),
            "{says}: {err}"
        );
    }
    assert!(!dir.path("o.mcap").exists());
    // Without --ros2 there is no format to write: a usage error.
    let out = support::run(&dir.run_dir(), &["export", p(&record), p(&bag)]);
    assert_eq!(out.status.code(), Some(2));
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}
