//! Smoke test of the `bus_latency` benchmark: runs it with `--quick --json` and checks
//! that all four measurements completed with every message accounted for. No timing
//! checks.

use std::process::Command;

#[test]
fn quick_run_reports_four_complete_rows() {
    let out = Command::new(env!("CARGO_BIN_EXE_bus_latency"))
        .args(["--quick", "--json"])
        .output()
        .expect("the benchmark starts");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "exit {}\nstdout:\n{stdout}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    assert_eq!(rows.len(), 4, "{stdout}");
    let mut seen = Vec::new();
    for r in &rows {
        // A child descheduled on a loaded machine may be overwritten (the cloud service
        // buffers 2): every message must be accounted for, received or counted lost.
        let (count, lost) = (r["count"].as_u64().unwrap(), r["lost"].as_u64().unwrap());
        assert_eq!(count + lost, 200, "{r}");
        assert!(count > 0, "{r}");
        seen.push((
            r["message"].as_str().unwrap().to_string(),
            r["mode"].as_str().unwrap().to_string(),
        ));
    }
    seen.sort();
    let want: Vec<(String, String)> = [
        ("cloud", "poll"),
        ("cloud", "wakeup"),
        ("small", "poll"),
        ("small", "wakeup"),
    ]
    .iter()
    .map(|(a, b)| (a.to_string(), b.to_string()))
    .collect();
    assert_eq!(seen, want);
}
