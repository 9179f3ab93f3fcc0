//! `realtime.toml` before launch: the file by itself and against the graph
//! (`aisle_node::realtime`), then against this host: every CPU it names must be one
//! this process may run on. The OS refusing a priority or locked memory is not an
//! error here: the nodes warn and run without them.

use aisle_config::ConfigError;
use aisle_node::Graph;
use aisle_node::realtime::{RealtimeConfig, available_cpus};
use std::path::Path;

/// Checks `dir/realtime.toml` (absent: every option off, nothing to check).
pub fn check(dir: &Path, graph: &Graph) -> Result<RealtimeConfig, String> {
    let config = RealtimeConfig::load_dir(dir, graph).map_err(|e| e.to_string())?;
    let path = aisle_node::realtime::path_in(dir);
    let cpus =
        available_cpus().map_err(|e| format!("{}: sched_getaffinity: {e}", path.display()))?;
    if let Err(e) = config.check_cpus(&cpus) {
        let text = aisle_config::read_capped(&path).unwrap_or_default();
        return Err(ConfigError::invalid(&path, &text, &e.key, e.reason).to_string());
    }
    Ok(config)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir_with(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("aisle-rt-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("realtime.toml"), text).unwrap();
        dir
    }

    fn error_of(name: &str, text: &str) -> String {
        let dir = dir_with(name, text);
        let err = check(&dir, &Graph::shipped()).unwrap_err();
        let _ = std::fs::remove_dir_all(&dir);
        err
    }

    #[test]
    fn the_shipped_file_is_valid_and_all_off() {
        let dir = aisle_config::testing::shipped_dir();
        let config = check(&dir, &Graph::shipped()).unwrap();
        for node in Graph::shipped().nodes() {
            assert!(config.options(&node.name).is_off(), "{}", node.name);
        }
    }

    #[test]
    fn a_missing_file_is_all_off() {
        let dir = std::env::temp_dir().join(format!("aisle-rt-none-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let config = check(&dir, &Graph::shipped()).unwrap();
        assert!(config.options("teb_controller").is_off());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn node_tables_override_the_default_key_by_key() {
        let dir = dir_with(
            "merge",
            "[default]\npriority = 60\nlock_memory = true\n[node.teb_controller]\npriority = 80\ncpus = [0]\n",
        );
        let config = check(&dir, &Graph::shipped()).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let teb = config.options("teb_controller");
        assert_eq!(
            (teb.priority, teb.lock_memory, teb.cpus),
            (80, true, vec![0])
        );
        let lidar = config.options("lidar");
        assert_eq!((lidar.priority, lidar.lock_memory), (60, true));
        assert!(lidar.cpus.is_empty());
    }

    #[test]
    fn bad_values_are_named_with_file_line_and_key() {
        let err = error_of("name", "[node.teb_controler]\npriority = 10\n");
        assert!(err.contains("realtime.toml:1"), "{err}");
        assert!(err.contains("node.teb_controler"), "{err}");
        assert!(err.contains("teb_controller"), "lists the nodes: {err}");
        let err = error_of("prio", "[default]\n\npriority = 100\n");
        assert!(err.contains("realtime.toml:3"), "{err}");
        assert!(
            err.contains("default.priority") && err.contains("100"),
            "{err}"
        );
        let err = error_of("key", "[default]\npriority_ = 1\n");
        assert!(
            err.contains("realtime.toml:2") && err.contains("priority_"),
            "{err}"
        );
        let err = error_of("twice", "[node.lidar]\ncpus = [0, 0]\n");
        assert!(
            err.contains("node.lidar.cpus[1]") && err.contains("twice"),
            "{err}"
        );
        let err = error_of("stack", "[default]\nprefault_stack_kb = 100000\n");
        assert!(err.contains("default.prefault_stack_kb"), "{err}");
        let err = error_of("wake", "[node.lidar]\nmax_wakeup_latency_us = 2000000\n");
        assert!(
            err.contains("realtime.toml:2") && err.contains("node.lidar.max_wakeup_latency_us"),
            "{err}"
        );
    }

    #[test]
    fn a_wakeup_latency_of_zero_is_a_request_and_a_node_may_override_it() {
        let dir = dir_with(
            "wake-ok",
            "[default]\nmax_wakeup_latency_us = 0\n[node.recorder]\nmax_wakeup_latency_us = 100\n",
        );
        let config = check(&dir, &Graph::shipped()).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let teb = config.options("teb_controller");
        assert_eq!(teb.max_wakeup_latency_us, Some(0));
        assert!(!teb.is_off());
        assert_eq!(config.options("recorder").max_wakeup_latency_us, Some(100));
    }

    #[test]
    fn a_cpu_this_host_lacks_is_refused() {
        let here = available_cpus().unwrap();
        let missing = (0..1024).find(|c| !here.contains(c)).unwrap();
        let err = error_of(
            "cpu",
            &format!("[node.mapper]\ncpus = [{}, {missing}]\n", here[0]),
        );
        assert!(err.contains("realtime.toml:2"), "{err}");
        assert!(err.contains("node.mapper.cpus[1]"), "{err}");
        assert!(
            err.contains(&format!("CPU {missing} is not available")),
            "{err}"
        );
    }
}
