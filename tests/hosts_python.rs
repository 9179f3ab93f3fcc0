//! An independent check of what crosses between hosts (issue 19): a Python program using
//! only `eclipse-zenoh` and the generated layouts (`python/examples/zenoh_robot_state.py`),
//! in a third network namespace that runs none of the group, finds the bridged
//! robot-state service among the link's offers, subscribes to its key expression and
//! decodes the poses; every pose it prints is the run's ground truth at that stamp, to
//! the bit.
//!
//! Needs root and `ip netns` (else it skips, saying why) and the Python module `zenoh`
//! (`pip install eclipse-zenoh==1.10.2`, the Rust zenoh's version): without it the test
//! skips, unless `AISLE_REQUIRE_PYTHON_SDK=1` (as `.ci/run` sets it, after installing it).

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::TestDir;
use support::netns::{Hosts, spread_run};

fn checkout() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Whether `python3` has the `zenoh` module; panics instead of skipping when required.
fn python_zenoh() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import zenoh"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        let why = "python3 has no `zenoh` module (pip install eclipse-zenoh==1.10.2)";
        assert!(
            std::env::var("AISLE_REQUIRE_PYTHON_SDK").as_deref() != Ok("1"),
            "{why} (AISLE_REQUIRE_PYTHON_SDK=1)"
        );
        eprintln!("skipped: {why}");
    }
    ok
}

/// One decoded sample: stamp and pose, as the script printed them.
struct Seen {
    stamp_ns: u64,
    pose: [f64; 3],
}

/// The script's `tick n stamp_ns s pose x y theta` lines (floats as Python's `repr`
/// writes them: the shortest text that reads back to the same bits, here too).
fn parse_lines(stdout: &str) -> Vec<Seen> {
    stdout
        .lines()
        .filter(|l| l.starts_with("tick "))
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(w.len(), 8, "{l}");
            let f = |s: &str| {
                s.parse::<f64>()
                    .unwrap_or_else(|_| panic!("not a float: {s} in {l}"))
            };
            Seen {
                stamp_ns: w[3].parse().unwrap(),
                pose: [f(w[5]), f(w[6]), f(w[7])],
            }
        })
        .collect()
}

#[test]
fn a_zenoh_subscriber_on_a_third_host_decodes_the_bridged_robot_state() {
    needs_netns!();
    if !python_zenoh() {
        return;
    }
    let hosts = Hosts::new(3);
    let run_c = TestDir::new("hosts-py-c");
    let script = checkout().join("python/examples/zenoh_robot_state.py");
    let endpoint = format!("tcp/{}:7447", Hosts::addr(0));
    // Started first, so it is subscribed before the run's first robot states.
    let watcher = hosts
        .command(
            2,
            &run_c.run_dir(),
            "python3",
            &[
                script.to_str().unwrap(),
                "--connect",
                &endpoint,
                "--count",
                "100",
                "--timeout",
                "90",
            ],
        )
        .spawn()
        .unwrap();
    let run = spread_run(&hosts, "hosts-py", &[], &[], None);
    let seen = watcher.wait_with_output().unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&seen.stdout),
        String::from_utf8_lossy(&seen.stderr),
    );
    assert!(seen.status.success(), "watcher: {stdout}{stderr}");
    let r = run.report.unwrap_or_else(|| {
        panic!("no report: {}", String::from_utf8_lossy(&run.out.stderr));
    });
    assert!(r.success, "{:?}\nhost b: {}", r.failure, run.b_err);
    assert!(stdout.starts_with("key aisle/iox2/v1/channel/"), "{stdout}");
    let lines = parse_lines(&stdout);
    assert_eq!(lines.len(), 100, "{stdout}");
    for s in &lines {
        let t = s.stamp_ns as f64 * 1e-9;
        let truth = r
            .driven_path
            .iter()
            .find(|p| p[0] == t)
            .unwrap_or_else(|| panic!("no pose at {t} s in the run"));
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&s.pose), bits(&truth[1..]), "at {t} s");
    }
    let moved = lines.windows(2).any(|w| w[0].pose != w[1].pose);
    assert!(moved, "the decoded robot never moved:\n{stdout}");
}
