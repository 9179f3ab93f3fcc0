//! Everything a run needs before anything is launched: the checked config directory,
//! the scene, mission, budgets, footprints, restart policy and graph, and the parsed fault
//! injections. Loading fails before a single process exists.

use super::RunOptions;
use crate::budgets::Budgets;
use crate::check::{self, ConfigFiles};
use crate::mission::{Footprints, MissionConfig};
use crate::restart::RestartConfig;
use aisle_config::scene::Scene;
use aisle_messages::NodeKind;
use aisle_node::Graph;
use anyhow::{anyhow, bail};

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
}

impl RunConfig {
    pub fn load(opts: &RunOptions) -> anyhow::Result<RunConfig> {
        let files = ConfigFiles::in_dir(&opts.config_dir);
        check::check_dir(&opts.config_dir).map_err(|e| anyhow!(e))?;
        let scene = Scene::load(&files.scene)?;
        let mission_path = opts.mission.clone().unwrap_or(files.mission.clone());
        let mission = MissionConfig::load(&mission_path, &scene)?;
        let budgets = aisle_config::load::<Budgets>(&files.budgets)?;
        let robot = aisle_config::load::<aisle_robot::RobotConfig>(&files.robot)?;
        let f = &robot.footprint;
        let footprints = Footprints {
            alone: f.alone.footprint(),
            alone_margin: f.alone.margin,
            carrying: f.carrying.footprint(),
            carrying_margin: f.carrying.margin,
        };
        let restart = aisle_config::load::<RestartConfig>(&files.restart)?;
        let graph = Graph::load_dir(&opts.config_dir)?;
        let kills = opts
            .kill
            .iter()
            .map(|k| parse_kill(k))
            .collect::<anyhow::Result<Vec<_>>>()?;
        if let Some(n) = &opts.crash_on_start
            && NodeKind::from_name(n).is_none_or(|k| !NodeKind::LAUNCHED.contains(&k))
        {
            bail!("--crash-on-start: no node `{n}`");
        }
        Ok(RunConfig {
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

/// `NODE@TICK` of `--kill`.
fn parse_kill(spec: &str) -> anyhow::Result<(NodeKind, u64)> {
    let (name, tick) = spec
        .split_once('@')
        .ok_or_else(|| anyhow!("--kill {spec}: expected NODE@TICK"))?;
    let kind = NodeKind::from_name(name)
        .filter(|k| NodeKind::LAUNCHED.contains(k))
        .ok_or_else(|| anyhow!("--kill {spec}: no node `{name}`"))?;
    let tick = tick
        .parse()
        .map_err(|_| anyhow!("--kill {spec}: `{tick}` is not a tick number"))?;
    Ok((kind, tick))
}
