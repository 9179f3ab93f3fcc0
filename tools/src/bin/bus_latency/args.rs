//! The command lines of the parent and of the child it starts, and the two choices they
//! carry (which message, how the child waits).
//!
//! Knows the flags and the message sizes; not the bus.

use crate::{CLOUD_POINTS, DEFAULT_COUNT, QUICK_COUNT};
use aisle_bus::Instance;
use aisle_messages::TickDone;
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A value of a two-way command-line choice.
pub(crate) trait Choice: Copy + Sized {
    /// Both values, in the order the error message names them.
    const ALL: [Self; 2];
    /// The flag that sets it.
    const FLAG: &'static str;
    fn name(self) -> &'static str;

    fn parse(s: &str) -> Result<Self> {
        match Self::ALL.iter().find(|c| c.name() == s) {
            Some(c) => Ok(*c),
            None => bail!(
                "{} must be {} or {}, not {s:?}",
                Self::FLAG,
                Self::ALL[0].name(),
                Self::ALL[1].name()
            ),
        }
    }
}

/// Which message is sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum Payload {
    Cloud,
    Small,
}

impl Choice for Payload {
    const ALL: [Payload; 2] = [Payload::Cloud, Payload::Small];
    const FLAG: &'static str = "--message";

    fn name(self) -> &'static str {
        match self {
            Payload::Cloud => "cloud",
            Payload::Small => "small",
        }
    }
}

impl Payload {
    /// Bytes the publisher writes per message: the used points for the cloud, the whole
    /// message for the small one.
    pub(crate) fn bytes(self) -> usize {
        match self {
            Payload::Cloud => CLOUD_POINTS * std::mem::size_of::<[f32; 3]>(),
            Payload::Small => std::mem::size_of::<TickDone>(),
        }
    }
}

/// How the child waits for a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum Mode {
    Wakeup,
    Poll,
}

impl Choice for Mode {
    const ALL: [Mode; 2] = [Mode::Wakeup, Mode::Poll];
    const FLAG: &'static str = "--mode";

    fn name(self) -> &'static str {
        match self {
            Mode::Wakeup => "wakeup",
            Mode::Poll => "poll",
        }
    }
}

pub(crate) struct ParentArgs {
    pub(crate) count: usize,
    pub(crate) json: bool,
}

pub(crate) struct ChildArgs {
    pub(crate) instance: Instance,
    pub(crate) mode: Mode,
    pub(crate) message: Payload,
    pub(crate) count: usize,
}

pub(crate) fn parent_args(args: &[String]) -> Result<ParentArgs> {
    let mut out = ParentArgs {
        count: DEFAULT_COUNT,
        json: false,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => out.count = QUICK_COUNT,
            "--json" => out.json = true,
            "--count" => out.count = parse_count(it.next())?,
            _ => {
                bail!("unknown argument {a:?} (usage: bus_latency [--quick] [--count N] [--json])")
            }
        }
    }
    Ok(out)
}

pub(crate) fn child_args(args: &[String]) -> Result<ChildArgs> {
    let (mut prefix, mut root, mut mode, mut message, mut count) = (None, None, None, None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--child" => {}
            "--prefix" => prefix = Some(value()?.clone()),
            "--root" => root = Some(PathBuf::from(value()?)),
            "--mode" => mode = Some(Mode::parse(value()?)?),
            "--message" => message = Some(Payload::parse(value()?)?),
            "--count" => count = Some(parse_count(Some(value()?))?),
            _ => bail!("unknown child argument {a:?}"),
        }
    }
    let instance = Instance::new(
        prefix.context("--prefix is required")?,
        root.context("--root is required")?,
    )?;
    Ok(ChildArgs {
        instance,
        mode: mode.context("--mode is required")?,
        message: message.context("--message is required")?,
        count: count.context("--count is required")?,
    })
}

fn parse_count(v: Option<&String>) -> Result<usize> {
    let v = v.context("--count needs a value")?;
    let n: usize = v
        .parse()
        .with_context(|| format!("--count {v:?} is not a number"))?;
    if n == 0 {
        bail!("--count must be at least 1");
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cloud_payload_is_the_scenario_scan() {
        assert_eq!(CLOUD_POINTS, 37_231);
        assert_eq!(Payload::Cloud.bytes(), 446_772);
        assert_eq!(Payload::Small.bytes(), 72);
    }

    #[test]
    fn arguments_parse_and_reject() {
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert_eq!(parent_args(&s(&["--quick"])).unwrap().count, QUICK_COUNT);
        assert!(parent_args(&s(&["--count", "0"])).is_err());
        assert!(parent_args(&s(&["--bogus"])).is_err());
        let c = child_args(&s(&[
            "--child",
            "--prefix",
            "abc_",
            "--root",
            "/tmp/x",
            "--mode",
            "poll",
            "--message",
            "small",
            "--count",
            "5",
        ]))
        .unwrap();
        assert_eq!(
            (c.mode, c.message, c.count),
            (Mode::Poll, Payload::Small, 5)
        );
        assert!(child_args(&s(&["--child", "--prefix", "abc_"])).is_err());
        let e = child_args(&s(&["--mode", "sleep"])).err().unwrap();
        assert_eq!(
            e.to_string(),
            "--mode must be wakeup or poll, not \"sleep\""
        );
    }
}
