//! `config/realtime.toml`: the real-time execution options of each node of the graph
//! (CPU affinity, SCHED_FIFO priority, locked memory, pre-faulted stack and heap, the
//! CPUs' wake-up latency), a
//! `[default]` table and per-node `[node.<name>]` overrides, every option off unless
//! set. A config directory without the file runs with every option off.
//!
//! Knows the file and what makes its values valid, by itself ([`Validate`]), against the
//! graph (the node names) and against this host (the CPUs this process may use); it
//! does not apply anything ([`super::apply`] does).

use crate::Graph;
use aisle_config::{ConfigError, InvalidKey, Validate};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Highest SCHED_FIFO priority Linux accepts (`sched_get_priority_max(SCHED_FIFO)`).
pub const MAX_PRIORITY: u32 = 99;
/// Largest stack pre-fault: half the usual 8 MiB main-thread stack, so the pre-fault
/// itself can never overflow it.
pub const MAX_PREFAULT_STACK_KB: u32 = 4096;
/// Largest heap pre-fault (1 GiB): far above what a node uses, a guard against a typo.
pub const MAX_PREFAULT_HEAP_KB: u32 = 1 << 20;
/// Largest wake-up latency asked (1 s): any idle state leaves faster, so a larger value
/// asks nothing.
pub const MAX_WAKEUP_LATENCY_US: u32 = 1_000_000;
/// The CPU indices `cpu_set_t` can hold.
const CPU_SET_SIZE: usize = 1024;

/// The options of one table as written: an absent key takes the `[default]` value
/// (for a node table) or "off" (for `[default]`).
#[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptionsFile {
    /// CPU indices the node's threads may run on (sched_setaffinity); absent: as
    /// started (normally every CPU).
    pub cpus: Option<Vec<usize>>,
    /// SCHED_FIFO priority 1..=99; 0: the normal time-sharing policy.
    pub priority: Option<u32>,
    /// No page of the process is paged out once touched: every page with CAP_IPC_LOCK
    /// or an unlimited RLIMIT_MEMLOCK, else what fits of what is mapped at startup
    /// (`lock.rs`).
    pub lock_memory: Option<bool>,
    /// KiB of stack touched once at startup, so the hot path never faults a stack page.
    pub prefault_stack_kb: Option<u32>,
    /// KiB of heap allocated, touched and freed at startup, with the allocator told to
    /// keep it (no trimming, no mmap for large blocks).
    pub prefault_heap_kb: Option<u32>,
    /// µs: while the node runs, no CPU enters an idle state slower to leave than this
    /// (PM QoS, `/dev/cpu_dma_latency`); 0 keeps idle CPUs polling.
    pub max_wakeup_latency_us: Option<u32>,
}

/// The whole file.
#[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealtimeConfig {
    #[serde(default)]
    pub default: OptionsFile,
    #[serde(default)]
    pub node: BTreeMap<String, OptionsFile>,
}

/// One node's options, resolved: what [`super::apply`] does.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Options {
    /// Empty: the affinity is left as the process started.
    pub cpus: Vec<usize>,
    /// 0: normal scheduling.
    pub priority: u32,
    pub lock_memory: bool,
    pub prefault_stack_kb: u32,
    pub prefault_heap_kb: u32,
    /// None: no request (0 is a request: poll).
    pub max_wakeup_latency_us: Option<u32>,
}

impl Options {
    /// Nothing to do.
    pub fn is_off(&self) -> bool {
        *self == Options::default()
    }
}

/// The file of a config directory.
pub fn path_in(config_dir: &Path) -> PathBuf {
    config_dir.join("realtime.toml")
}

impl RealtimeConfig {
    /// `config_dir/realtime.toml`, checked by itself and against `graph`'s node names;
    /// every option off when the directory has no such file.
    pub fn load_dir(config_dir: &Path, graph: &Graph) -> Result<RealtimeConfig, ConfigError> {
        let path = path_in(config_dir);
        if !path.exists() {
            return Ok(RealtimeConfig::default());
        }
        let (config, text) = aisle_config::load_toml::<RealtimeConfig>(&path)?;
        let invalid = |e: InvalidKey| ConfigError::invalid(&path, &text, &e.key, e.reason);
        config.validate().map_err(invalid)?;
        config.check_names(graph).map_err(invalid)?;
        Ok(config)
    }

    /// The options of the node `name`.
    pub fn options(&self, name: &str) -> Options {
        let d = &self.default;
        let n = self.node.get(name);
        let pick = |f: fn(&OptionsFile) -> Option<u32>| n.and_then(f).or(f(d)).unwrap_or(0);
        Options {
            cpus: n
                .and_then(|n| n.cpus.clone())
                .or_else(|| d.cpus.clone())
                .unwrap_or_default(),
            priority: pick(|o| o.priority),
            lock_memory: n
                .and_then(|n| n.lock_memory)
                .or(d.lock_memory)
                .unwrap_or(false),
            prefault_stack_kb: pick(|o| o.prefault_stack_kb),
            prefault_heap_kb: pick(|o| o.prefault_heap_kb),
            max_wakeup_latency_us: n
                .and_then(|n| n.max_wakeup_latency_us)
                .or(d.max_wakeup_latency_us),
        }
    }

    /// Every `[node.<name>]` names a node of the graph.
    pub fn check_names(&self, graph: &Graph) -> Result<(), InvalidKey> {
        let names: Vec<&str> = graph.nodes().iter().map(|n| n.name.as_str()).collect();
        match self.node.keys().find(|k| !names.contains(&k.as_str())) {
            Some(name) => Err(InvalidKey::new(
                format!("node.{name}"),
                format!(
                    "no node `{name}` in the graph; nodes are {}",
                    names.join(", ")
                ),
            )),
            None => Ok(()),
        }
    }

    /// Every CPU named is one this process may run on (`available`, from
    /// [`super::available_cpus`]): a CPU the host lacks is an error before launch.
    pub fn check_cpus(&self, available: &[usize]) -> Result<(), InvalidKey> {
        let tables = std::iter::once(("default".to_string(), &self.default)).chain(
            self.node
                .iter()
                .map(|(name, o)| (format!("node.{name}"), o)),
        );
        for (table, o) in tables {
            for (i, cpu) in o.cpus.iter().flatten().enumerate() {
                if !available.contains(cpu) {
                    return Err(InvalidKey::new(
                        format!("{table}.cpus[{i}]"),
                        format!(
                            "CPU {cpu} is not available here; this process may run on CPUs {}",
                            list(available)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

fn list(cpus: &[usize]) -> String {
    let v: Vec<String> = cpus.iter().map(|c| c.to_string()).collect();
    v.join(", ")
}

impl Validate for RealtimeConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        validate_table("default", &self.default)?;
        for (name, o) in &self.node {
            validate_table(&format!("node.{name}"), o)?;
        }
        Ok(())
    }
}

fn validate_table(table: &str, o: &OptionsFile) -> Result<(), InvalidKey> {
    let key = |field: &str| format!("{table}.{field}");
    if let Some(p) = o.priority
        && p > MAX_PRIORITY
    {
        return Err(InvalidKey::new(
            key("priority"),
            format!("SCHED_FIFO priorities are 1..={MAX_PRIORITY} (0: normal scheduling), got {p}"),
        ));
    }
    if let Some(cpus) = &o.cpus {
        if cpus.is_empty() {
            return Err(InvalidKey::new(
                key("cpus"),
                "an empty list would allow no CPU; leave the key out to leave the affinity open",
            ));
        }
        for (i, &cpu) in cpus.iter().enumerate() {
            if cpu >= CPU_SET_SIZE {
                return Err(InvalidKey::new(
                    format!("{table}.cpus[{i}]"),
                    format!("CPU indices are below {CPU_SET_SIZE}, got {cpu}"),
                ));
            }
            if cpus[..i].contains(&cpu) {
                return Err(InvalidKey::new(
                    format!("{table}.cpus[{i}]"),
                    format!("CPU {cpu} is listed twice"),
                ));
            }
        }
    }
    if let Some(kb) = o.prefault_stack_kb {
        aisle_config::checks::in_range(&key("prefault_stack_kb"), kb, 0, MAX_PREFAULT_STACK_KB)?;
    }
    if let Some(kb) = o.prefault_heap_kb {
        aisle_config::checks::in_range(&key("prefault_heap_kb"), kb, 0, MAX_PREFAULT_HEAP_KB)?;
    }
    if let Some(us) = o.max_wakeup_latency_us {
        aisle_config::checks::in_range(
            &key("max_wakeup_latency_us"),
            us,
            0,
            MAX_WAKEUP_LATENCY_US,
        )?;
    }
    Ok(())
}
