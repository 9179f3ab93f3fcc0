//! Everything a run needs before anything is launched: the checked config directory,
//! the scene, mission, budgets, footprints, restart policy and graph, and the parsed fault
//! injections; the outputs locked against a concurrent command writing them. Loading
//! fails before a single process exists.

use super::RunOptions;
use crate::check::{self, ConfigFiles};
use crate::mission::{Footprints, MissionConfig};
use crate::restart::RestartConfig;
use aisle_config::scene::Scene;
use aisle_messages::NodeKind;
use aisle_node::Graph;
use aisle_tools::latency::Budgets;
use aisle_tools::output_lock::{LockError, OutputLock};
use anyhow::{anyhow, bail};
use std::path::{Path, PathBuf};

/// The configuration of one run, loaded and checked.
pub(super) struct RunConfig {
    pub restart: RestartConfig,
    /// `--kill NODE@TICK`: nodes to SIGKILL at a tick.
    pub kills: Vec<(NodeKind, u64)>,
    pub scene: Scene,
    pub mission: MissionConfig,
    pub budgets: Budgets,
    pub footprints: Footprints,
    /// Who launches, acknowledges and retains what (`config/graph.toml`).
    pub graph: Graph,
    /// Where the recorder writes, when `--record` asked for one it may write.
    pub record: Option<PathBuf>,
    /// `--hosts`: the group spread over hosts; `None` runs every node here.
    pub placement: Option<aisle_link::Placement>,
    /// The outputs (`--record`, `--report`, `--samples`) locked for this run: another
    /// command naming one of them is refused until the run ends.
    pub _outputs: Vec<OutputLock>,
}

impl RunConfig {
    pub fn load(opts: &RunOptions) -> anyhow::Result<RunConfig> {
        // Outputs first: a bad path must not cost a whole mission.
        for (flag, p) in [
            ("--report", &opts.report),
            ("--samples", &opts.samples),
            ("--record", &opts.record),
        ] {
            if let Some(p) = p {
                output_shape(flag, p)?;
            }
        }
        // The live view's port, before launch: a recorder that cannot listen exits, and
        // the record it would have written is lost with it.
        if let Some(addr) = opts.foxglove {
            std::net::TcpListener::bind(addr)
                .map_err(|e| anyhow!("--foxglove {addr}: cannot listen there: {e}"))?;
        }
        let files = ConfigFiles::in_dir(&opts.config_dir);
        let mission_path = opts.mission.clone().unwrap_or(files.mission.clone());
        let outputs = [
            ("--report", opts.report.as_deref()),
            ("--samples", opts.samples.as_deref()),
            ("--record", opts.record.as_deref()),
        ];
        let outputs: Vec<(&str, &Path)> = outputs
            .into_iter()
            .filter_map(|(flag, p)| Some((flag, p?)))
            .collect();
        let mut inputs: Vec<(&str, &Path)> = vec![("the mission", mission_path.as_path())];
        inputs.extend(files.all().into_iter().map(|p| ("a config file", p)));
        crate::file_roles::distinct(&inputs, &outputs).map_err(|e| anyhow!(e))?;
        let (_outputs, record) = lock_outputs(opts)?;
        check::check_dir(&opts.config_dir).map_err(|e| anyhow!(e))?;
        let ground = check::Loaded::load(&files).map_err(|e| anyhow!(e))?;
        let mission =
            check::load_mission(&files, &ground, &mission_path).map_err(|e| anyhow!(e))?;
        let scene = ground.scene;
        let budgets = aisle_config::load::<Budgets>(&files.budgets)?;
        let robot = aisle_config::load::<aisle_robot::RobotConfig>(&files.robot)?;
        let f = &robot.footprint;
        let footprints = Footprints {
            alone: f.alone.footprint(),
            alone_margin: f.alone.margin,
            carrying: f.carrying.footprint(),
            carrying_margin: f.carrying.margin,
            height: robot.body.height,
        };
        let restart = aisle_config::load::<RestartConfig>(&files.restart)?;
        let graph = Graph::load_dir(&opts.config_dir)?;
        let kills = opts
            .kill
            .iter()
            .map(|k| parse_kill(k, &graph))
            .collect::<anyhow::Result<Vec<_>>>()?;
        if let Some(n) = &opts.crash_on_start
            && NodeKind::from_name(n).is_none_or(|k| !NodeKind::LAUNCHED.contains(&k))
        {
            bail!("--crash-on-start: no node `{n}`");
        }
        let placement = opts
            .hosts
            .as_deref()
            .map(|p| crate::remote::load_placement(p, &graph))
            .transpose()?;
        Ok(RunConfig {
            _outputs,
            placement,
            record,
            restart,
            kills,
            scene,
            mission,
            budgets,
            footprints,
            graph,
        })
    }
}

/// `NODE@TICK` of `--kill`: a launched built-in node or an external one of the graph.
fn parse_kill(spec: &str, graph: &Graph) -> anyhow::Result<(NodeKind, u64)> {
    let (name, tick) = spec
        .split_once('@')
        .ok_or_else(|| anyhow!("--kill {spec}: expected NODE@TICK"))?;
    let kind = NodeKind::from_name(name)
        .filter(|k| NodeKind::LAUNCHED.contains(k))
        .or_else(|| graph.external().find(|n| n.name == name).map(|n| n.kind()))
        .ok_or_else(|| anyhow!("--kill {spec}: no node `{name}` to kill"))?;
    let tick = tick
        .parse()
        .map_err(|_| anyhow!("--kill {spec}: `{tick}` is not a tick number"))?;
    Ok((kind, tick))
}

/// Locks the run's outputs before launch, each the check that the run can write it:
/// two runs writing one file would interleave into a corrupt one. The record is not the
/// mission: one the run may not write (permissions, a read-only file system) is a
/// warning and the run goes on unrecorded (`None`); one another command writes is an
/// error, as a report is.
fn lock_outputs(opts: &RunOptions) -> anyhow::Result<(Vec<OutputLock>, Option<PathBuf>)> {
    let mut locks = Vec::with_capacity(3);
    for (flag, p) in [("--report", &opts.report), ("--samples", &opts.samples)] {
        if let Some(p) = p {
            locks.push(writable_output(flag, p)?);
        }
    }
    let Some(record) = &opts.record else {
        return Ok((locks, None));
    };
    match OutputLock::acquire("--record", record) {
        Ok(lock) => locks.push(lock),
        Err(e @ LockError::Busy { .. }) => return Err(e.into()),
        Err(e) => {
            tracing::warn!("{e:#}; the run goes on unrecorded");
            return Ok((locks, None));
        }
    }
    Ok((locks, Some(record.clone())))
}

/// An output file the run will write at its end, locked for it
/// ([`crate::file_roles::writable_output`]).
pub(crate) fn writable_output(flag: &str, path: &Path) -> anyhow::Result<OutputLock> {
    crate::file_roles::writable_output(flag, path).map_err(|e| anyhow!(e))
}

fn output_shape(flag: &str, path: &Path) -> anyhow::Result<()> {
    crate::file_roles::output_shape(flag, path).map_err(|e| anyhow!(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_paths_are_checked_before_the_run() {
        let dir = std::env::temp_dir().join(format!("aisle-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        drop(writable_output("--report", &dir.join("r.json")).unwrap());
        let e = writable_output("--report", Path::new("/nonexistent/dir/x.json")).unwrap_err();
        let e = e.to_string();
        assert!(
            e.contains("/nonexistent/dir/x.json") && e.contains("No such file"),
            "{e}"
        );
        let e = writable_output("--record", &dir).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        let e = writable_output("--report", Path::new(""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("empty"), "{e}");
        // Root may write anywhere: the permission case only means something otherwise.
        if unsafe { libc::geteuid() } != 0 {
            let e = writable_output("--report", Path::new("/proc/x.json")).unwrap_err();
            assert!(e.to_string().contains("cannot write"), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
