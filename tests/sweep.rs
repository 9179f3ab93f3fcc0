//! `aisle sweep` end to end on two cheap families: the JSON's shape and that its counts
//! add up (not that every scenario succeeds: that is the stack's business).

mod support;

use support::{TestDir, command, config_dir, run_dir_leftovers};

#[test]
fn a_small_sweep_writes_a_table_and_json_whose_counts_add_up() {
    let dir = TestDir::new("sweep");
    let out = dir.path("out");
    let cfg = config_dir();
    let args = [
        "sweep",
        "--count",
        "4",
        "--jobs",
        "2",
        "--seed",
        "3",
        "--families",
        "moved,start",
        "--out",
        out.to_str().unwrap(),
        "--config-dir",
        cfg.to_str().unwrap(),
    ];
    let o = command(&dir.run_dir(), &args).output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    let code = o.status.code();
    assert!(
        matches!(code, Some(0 | 1)),
        "exit {code:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("| **all** | 4 |"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert!(out.join("sweep.md").is_file());
    let scenarios = json["scenarios"].as_array().unwrap();
    assert_eq!(scenarios.len(), 4);
    for s in scenarios {
        assert!(
            ["moved", "start"].contains(&s["family"].as_str().unwrap()),
            "{s}"
        );
        assert!(s["seed"].as_u64().unwrap() >= 3_000_000);
        let outcome = s["outcome"].as_str().unwrap();
        assert!(["success", "failure", "error"].contains(&outcome), "{s}");
        assert!(
            std::path::Path::new(s["config_dir"].as_str().unwrap())
                .join("warehouse.toml")
                .is_file()
        );
        assert!(s["oracle"]["outcome"].is_string(), "{s}");
        if s["feasible"] == false {
            assert_ne!(outcome, "success", "a run that succeeded is feasible: {s}");
        }
    }
    let families = json["per_family"].as_array().unwrap();
    assert_eq!(families.len(), 2);
    let all = &json["all"];
    let field = |v: &serde_json::Value, k: &str| v[k].as_u64().unwrap();
    let sum = |k: &str| families.iter().map(|f| field(f, k)).sum::<u64>();
    for k in [
        "scenarios",
        "feasible",
        "succeeded",
        "infeasible",
        "errors",
        "collisions",
    ] {
        assert_eq!(sum(k), field(all, k), "{k}");
    }
    assert_eq!(field(all, "scenarios"), 4);
    assert_eq!(field(all, "feasible") + field(all, "infeasible"), 4);
    assert!(field(all, "succeeded") <= field(all, "feasible"));
    let expected = json["all_as_expected"].as_bool().unwrap();
    assert_eq!(expected, code == Some(0));
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
}
