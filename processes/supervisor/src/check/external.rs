//! The nodes of the user's own that `graph.toml` declares (`command`): each program must
//! exist where `run` will start it (a path relative to the user's graph file, or a name
//! on `PATH`), and a `<node>.toml` beside the config is that node's own file (its
//! contents are the node's to check). Knows the graph and the file system, not what the
//! nodes do.

use aisle_node::Graph;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

/// The external nodes' own config files present in `dir`, after checking that every
/// external node's program can be started.
pub fn check(dir: &Path, graph: &Graph) -> Result<Vec<PathBuf>, String> {
    let source = crate::cli::config::source_of(&aisle_node::graph::path_in(dir));
    let graph_dir = &graph_dir(dir);
    let mut own = Vec::new();
    for node in graph.nodes() {
        let Some(argv) = &node.command else { continue };
        let Some(program) = argv.first() else {
            continue;
        };
        if !startable(program, graph_dir) {
            return Err(format!(
                "{}: node `{}`: command `{program}` {}",
                source.display(),
                node.name,
                if program.contains('/') {
                    format!(
                        "is not an executable file (relative to {})",
                        graph_dir.display()
                    )
                } else {
                    "is not an executable on PATH".to_string()
                }
            ));
        }
        let file = dir.join(format!("{}.toml", node.name));
        if file.exists() {
            own.push(file);
        }
    }
    Ok(own)
}

/// The directory of the user's graph file of config directory `dir` (for an overlay,
/// not the assembled copy's): what a node's relative command is relative to, and where
/// it runs.
pub fn graph_dir(dir: &Path) -> PathBuf {
    let source = crate::cli::config::source_of(&aisle_node::graph::path_in(dir));
    source.parent().unwrap_or(dir).to_path_buf()
}

/// Whether `program` names an executable file: a path (relative to `graph_dir`), or a
/// name found on `PATH`.
fn startable(program: &str, graph_dir: &Path) -> bool {
    let executable = |p: &Path| {
        p.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if program.contains('/') {
        return executable(&graph_dir.join(program));
    }
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| executable(&d.join(program))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_program_is_found_by_path_or_on_path() {
        let dir = tempfile::tempdir().unwrap();
        let script = dir.path().join("node.sh");
        std::fs::write(&script, "#!/bin/sh\n").unwrap();
        assert!(!startable("./node.sh", dir.path()), "not executable yet");
        std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
        assert!(startable("./node.sh", dir.path()));
        assert!(!startable("./missing.sh", dir.path()));
        assert!(startable("sh", dir.path()));
        assert!(!startable("no-such-program-aisle", dir.path()));
    }

    /// The shipped config with one node of the user's own, `watcher`, run as `program`.
    fn config_with(program: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let shipped = aisle_config::testing::shipped_dir();
        for e in std::fs::read_dir(&shipped).unwrap().flatten() {
            if e.path().is_file() {
                std::fs::copy(e.path(), dir.path().join(e.file_name())).unwrap();
            }
        }
        let graph = dir.path().join("graph.toml");
        let mut text = std::fs::read_to_string(&graph).unwrap();
        text.push_str(&format!(
            "\n[[node]]\nname = \"watcher\"\ncommand = [\"{program}\"]\npublishes = []\n\
             subscribes = [\"aisle/tick\"]\nacknowledges = \"none\"\n"
        ));
        std::fs::write(&graph, text).unwrap();
        dir
    }

    #[test]
    fn a_nodes_own_file_is_accepted_and_a_missing_program_refused() {
        let ok = config_with("sh");
        std::fs::write(ok.path().join("watcher.toml"), "margin = 0.2\n").unwrap();
        let checked = crate::check::check_dir(ok.path()).unwrap();
        assert!(checked.iter().any(|p| p.ends_with("watcher.toml")));
        // A file named after no node is still a typo.
        std::fs::write(ok.path().join("wacher.toml"), "").unwrap();
        let e = crate::check::check_dir(ok.path()).unwrap_err();
        assert!(e.contains("wacher.toml: not a file aisle reads"), "{e}");
        let missing = config_with("./watcher.sh");
        let e = crate::check::check_dir(missing.path()).unwrap_err();
        assert!(
            e.contains("node `watcher`: command `./watcher.sh` is not an executable file"),
            "{e}"
        );
    }
}
