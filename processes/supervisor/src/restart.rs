//! Restart policy (`config/restart.toml`) and the count of restarts against it.
//! Pure bookkeeping: it is told when a node died and answers whether it may restart.

use aisle_config::{InvalidKey, Validate, checks};
use aisle_messages::NodeKind;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Shortest realtime heartbeat timeout: three heartbeat periods (50 ms each), so one
/// late heartbeat never kills a node.
const MIN_REALTIME_TIMEOUT_S: f64 = 0.15;

/// Shortest link silence that counts as a cut: three beats of a host daemon.
const MIN_LINK_SILENT_S: f64 = 0.06;

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Policy {
    pub max_restarts: u32,
    pub window_s: f64,
    /// Lockstep: a ready node silent this long (wall time) is killed and restarted. The
    /// sim clock waits for it meanwhile, so nothing moves.
    pub heartbeat_timeout_s: f64,
    /// Realtime: the same, a few heartbeat periods, because the robot keeps moving.
    #[serde(default = "default_realtime_timeout")]
    pub realtime_heartbeat_timeout_s: f64,
    /// A node (re)started but not yet ready may be silent this long (loading its
    /// config, building maps, resuming).
    #[serde(default = "default_start_timeout")]
    pub start_timeout_s: f64,
}

fn default_realtime_timeout() -> f64 {
    0.2
}

fn default_start_timeout() -> f64 {
    20.0
}

/// Per-node overrides: any field left out takes the default's value.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolicyOverride {
    pub max_restarts: Option<u32>,
    pub window_s: Option<f64>,
    pub heartbeat_timeout_s: Option<f64>,
    pub realtime_heartbeat_timeout_s: Option<f64>,
    pub start_timeout_s: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RestartConfig {
    pub default: Policy,
    #[serde(default)]
    pub node: BTreeMap<String, PolicyOverride>,
    /// A spread run's links to other hosts (`aisle run --hosts`).
    #[serde(default)]
    pub link: LinkPolicy,
}

/// When a link to another host counts as down, and how long it may stay down.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkPolicy {
    /// A host whose daemon beat (every 20 ms) is silent this long is cut off: the robot
    /// stops and its nodes are held, not declared hung.
    pub silent_s: f64,
    /// A link down this long ends the run as a failure naming the host.
    pub down_limit_s: f64,
}

impl Default for LinkPolicy {
    fn default() -> Self {
        LinkPolicy {
            silent_s: 0.1,
            down_limit_s: 10.0,
        }
    }
}

impl Validate for RestartConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        if let Some(name) = self
            .node
            .keys()
            .find(|n| NodeKind::from_name(n).is_none_or(|k| !NodeKind::LAUNCHED.contains(&k)))
        {
            let names: Vec<&str> = NodeKind::LAUNCHED.iter().map(|k| k.name()).collect();
            return Err(InvalidKey::new(
                format!("node.{name}"),
                format!("no node `{name}`; nodes are {}", names.join(", ")),
            ));
        }
        checks::at_least("link.silent_s", self.link.silent_s, MIN_LINK_SILENT_S)?;
        checks::at_least(
            "link.down_limit_s",
            self.link.down_limit_s,
            self.link.silent_s,
        )?;
        for kind in NodeKind::LAUNCHED {
            let p = self.policy(kind);
            let key = |field: &str| {
                if self.node.contains_key(kind.name()) {
                    format!("node.{}.{field}", kind.name())
                } else {
                    format!("default.{field}")
                }
            };
            if !(p.window_s.is_finite() && p.window_s > 0.0) {
                return Err(InvalidKey::new(
                    key("window_s"),
                    format!("must be a positive number of seconds, got {}", p.window_s),
                ));
            }
            checks::at_least(&key("heartbeat_timeout_s"), p.heartbeat_timeout_s, 0.5)?;
            checks::at_least(
                &key("realtime_heartbeat_timeout_s"),
                p.realtime_heartbeat_timeout_s,
                MIN_REALTIME_TIMEOUT_S,
            )?;
            checks::at_least(&key("start_timeout_s"), p.start_timeout_s, 1.0)?;
        }
        Ok(())
    }
}

impl RestartConfig {
    pub fn policy(&self, kind: NodeKind) -> Policy {
        let d = self.default;
        match self.node.get(kind.name()) {
            None => d,
            Some(o) => Policy {
                max_restarts: o.max_restarts.unwrap_or(d.max_restarts),
                window_s: o.window_s.unwrap_or(d.window_s),
                heartbeat_timeout_s: o.heartbeat_timeout_s.unwrap_or(d.heartbeat_timeout_s),
                realtime_heartbeat_timeout_s: o
                    .realtime_heartbeat_timeout_s
                    .unwrap_or(d.realtime_heartbeat_timeout_s),
                start_timeout_s: o.start_timeout_s.unwrap_or(d.start_timeout_s),
            },
        }
    }
}

/// Restart times per node (seconds since the run started).
#[derive(Debug, Default)]
pub struct RestartBook {
    times: BTreeMap<&'static str, Vec<f64>>,
}

impl RestartBook {
    /// Records a death of `kind` at `now_s`; `Ok(n)` when restart number n within the
    /// window is allowed, `Err(n)` when the policy is exhausted.
    pub fn allow(&mut self, kind: NodeKind, policy: &Policy, now_s: f64) -> Result<u32, u32> {
        let times = self.times.entry(kind.name()).or_default();
        times.retain(|&t| now_s - t <= policy.window_s);
        times.push(now_s);
        let n = times.len() as u32;
        if n > policy.max_restarts {
            // Refused: this death is not a restart, so it is not counted as one.
            times.pop();
            Err(n - 1)
        } else {
            Ok(n)
        }
    }

    pub fn total(&self) -> u32 {
        self.times.values().map(|v| v.len() as u32).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restarts_are_limited_within_the_window() {
        let p = Policy {
            max_restarts: 2,
            window_s: 10.0,
            heartbeat_timeout_s: 5.0,
            realtime_heartbeat_timeout_s: 0.2,
            start_timeout_s: 20.0,
        };
        let mut book = RestartBook::default();
        assert_eq!(book.allow(NodeKind::Lidar, &p, 0.0), Ok(1));
        assert_eq!(book.allow(NodeKind::Lidar, &p, 1.0), Ok(2));
        assert_eq!(book.allow(NodeKind::Mapper, &p, 1.0), Ok(1));
        assert_eq!(book.allow(NodeKind::Lidar, &p, 2.0), Err(2));
        // The refused death is no restart: the report's total says what was restarted.
        assert_eq!(book.total(), 3);
        // Old restarts leave the window.
        let mut book = RestartBook::default();
        book.allow(NodeKind::Lidar, &p, 0.0).unwrap();
        book.allow(NodeKind::Lidar, &p, 1.0).unwrap();
        assert_eq!(book.allow(NodeKind::Lidar, &p, 20.0), Ok(1));
    }

    #[test]
    fn the_shipped_policy_loads_and_overrides_apply() {
        let shipped = aisle_config::testing::shipped("restart.toml");
        let cfg = aisle_config::load::<RestartConfig>(&shipped).unwrap();
        assert!(cfg.policy(NodeKind::Lidar).max_restarts >= 1);
        assert!(cfg.link.silent_s < cfg.link.down_limit_s);
        let text = "[default]\nmax_restarts = 1\nwindow_s = 5.0\nheartbeat_timeout_s = 2.0\n[node.lidar]\nmax_restarts = 4\n";
        let p = std::env::temp_dir().join(format!("aisle-restart-{}.toml", std::process::id()));
        std::fs::write(&p, text).unwrap();
        let cfg = aisle_config::load::<RestartConfig>(&p).unwrap();
        assert_eq!(cfg.policy(NodeKind::Lidar).max_restarts, 4);
        assert_eq!(cfg.policy(NodeKind::Mapper).max_restarts, 1);
        assert_eq!(
            cfg.policy(NodeKind::Mapper).realtime_heartbeat_timeout_s,
            0.2
        );
        // The error a file of `t` gives.
        let refused = |t: &str| {
            std::fs::write(&p, t).unwrap();
            aisle_config::load::<RestartConfig>(&p)
                .unwrap_err()
                .to_string()
        };
        let e = refused(&text.replace("max_restarts = 4", "realtime_heartbeat_timeout_s = 0.05"));
        assert!(e.contains("node.lidar.realtime_heartbeat_timeout_s"), "{e}");
        let e = refused(&format!(
            "{text}[link]\nsilent_s = 0.01\ndown_limit_s = 5.0\n"
        ));
        assert!(e.contains("link.silent_s"), "{e}");
        let e = refused(&format!(
            "{text}[link]\nsilent_s = 0.2\ndown_limit_s = 0.1\n"
        ));
        assert!(e.contains("link.down_limit_s"), "{e}");
        let e = refused(&text.replace("[node.lidar]", "[node.lidr]"));
        assert!(e.contains("node.lidr"), "{e}");
        let _ = std::fs::remove_file(&p);
    }
}
