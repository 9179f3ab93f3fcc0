//! What a recording says about its run besides the samples: the run's metadata
//! (`aisle`), the config files as attachments, and the recorder's own account of what it
//! lost (`aisle.recorder`).
//!
//! Knows the node arguments, the instance announcement and the config directory; not the
//! bus or the file layout (it only queues jobs for the writer thread).

use super::RecordSummary;
use super::write::Job;
use crate::writer::media_type;
use aisle_bus::{NodeArgs, NodeError, clock};
use aisle_messages::InstanceInfo;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc;

/// Queues the run's metadata and every config file (a file that cannot be read is
/// logged and left out).
pub(super) fn queue_run_info(
    jobs: &mpsc::Sender<Job>,
    args: &NodeArgs,
    info: &InstanceInfo,
    log_clock: &str,
) {
    let now = clock::monotonic_ns();
    let mut meta = run_metadata(args, info);
    meta.insert("log_time".into(), log_clock.into());
    let _ = jobs.send(Job::Metadata("aisle".into(), meta));
    for (name, path) in config_files(&args.config_dir) {
        match std::fs::read(&path) {
            Ok(data) => {
                let _ = jobs.send(Job::Attach {
                    name,
                    media_type: media_type(&path),
                    data,
                    time: now,
                });
            }
            Err(e) => tracing::warn!("recorder: cannot attach {}: {e}", path.display()),
        }
    }
}

/// The recorder's metadata: losses per service and in total, and what ended the
/// recording when it was an error.
pub(super) fn loss_metadata(
    summary: &RecordSummary,
    ended: &Result<(), NodeError>,
) -> BTreeMap<String, String> {
    let mut stats = BTreeMap::new();
    for (name, map) in [
        ("lost_in_bus", &summary.lost_in_bus),
        ("lost_in_queue", &summary.lost_in_queue),
    ] {
        for (service, n) in map {
            stats.insert(format!("{name}:{service}"), n.to_string());
        }
    }
    stats.insert("lost_total".into(), summary.lost().to_string());
    if let Err(e) = ended {
        stats.insert("ended_by".into(), e.to_string());
    }
    stats
}

fn run_metadata(args: &NodeArgs, info: &InstanceInfo) -> BTreeMap<String, String> {
    BTreeMap::from([
        ("schema_hash".into(), aisle_messages::schema_hash_hex()),
        (
            "announced_schema_hash".into(),
            format!("{:016x}", info.schema_hash),
        ),
        ("seed".into(), info.seed.to_string()),
        ("mode".into(), info.mode.to_string()),
        ("instance".into(), args.instance.prefix.clone()),
        ("dt_ns".into(), args.dt_ns.to_string()),
        ("controller_every".into(), args.controller_every.to_string()),
        (
            "start".into(),
            format!("{} {} {}", args.start[0], args.start[1], args.start[2]),
        ),
        ("config_dir".into(), args.config_dir.display().to_string()),
    ])
}

/// Regular files of the config directory and its direct subdirectories, sorted, named
/// relative to it.
pub fn config_files(dir: &Path) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    let mut dirs = vec![(dir.to_path_buf(), 0)];
    while let Some((d, depth)) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.filter_map(Result::ok) {
            let path = e.path();
            let Ok(ft) = e.file_type() else { continue };
            if ft.is_dir() && depth < 1 {
                dirs.push((path, depth + 1));
            } else if ft.is_file() {
                let name = path
                    .strip_prefix(dir)
                    .unwrap_or(&path)
                    .to_string_lossy()
                    .into_owned();
                out.push((name, path));
            }
        }
    }
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_files_are_listed_sorted_and_relative() {
        let dir = std::env::temp_dir().join(format!("aisle-tools-cfg-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("maps")).unwrap();
        std::fs::write(dir.join("b.toml"), "x").unwrap();
        std::fs::write(dir.join("a.urdf"), "y").unwrap();
        std::fs::write(dir.join("maps/m.pgm"), "z").unwrap();
        let files = config_files(&dir);
        let names: Vec<_> = files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["a.urdf", "b.toml", "maps/m.pgm"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
