//! `aisle profile`: the latency table of a recorded run, computed by [`crate::latency`]
//! exactly as `aisle run` computes it live, and scored against the `budgets.toml`
//! attached to the record (or one given explicitly).
//!
//! Figures come from the message headers, not from the recorder's receive times, so the
//! recorder's own delays do not distort them: stage compute time is `TickDone.compute_ns`;
//! end to end is `publish_wall_ns - tick_wall_ns` of the controller's `Trajectory`; the
//! planner's is `PlanResponse.solve_ns`; the tick release is each `Tick`'s start. Besides
//! what `run` shows, the output latency of a few services (`latency <service>`: tick
//! start -> published, not scored) and a histogram per series.
//! Knows the recorded file and the headers; not how the stages compute. The plot is
//! [`svg`].

pub mod svg;

use crate::aligned::AlignedBuf;
use crate::latency::{Budgets, LatencyTable, SampleBook, format_table};
use crate::payload_fields::{PUBLISH_WALL_AT, TICK_AT, TICK_WALL_AT, u64_at};
use crate::reader::{ReadError, RecordFile};
use aisle_messages::topics::names as s;
use aisle_messages::{Header, NodeKind, PlanResponse, StageStatus, Tick, TickDone, Trajectory};
use std::fmt::Write as _;
use std::path::Path;

/// Name of the budgets attachment a record carries (a config file, see the recorder).
pub const BUDGETS_ATTACHMENT: &str = "budgets.toml";

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ProfileOptions {
    /// Budgets to score against instead of the ones attached to the record.
    pub budgets: Option<Budgets>,
}

#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: no latency data (no TickDone, Trajectory or Tick messages were recorded)")]
    Empty { path: String },
    #[error("{0}")]
    Budgets(#[from] aisle_config::ConfigError),
    #[error("cannot draw the plot: {0}")]
    Plot(String),
    #[error("cannot write {path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
}

/// What the figures were scored against.
#[derive(Debug, Clone, PartialEq)]
pub enum BudgetSource {
    Given,
    Attached,
    /// The record carries no `budgets.toml`: nothing is scored.
    None,
}

#[derive(Debug, Clone)]
pub struct ProfileReport {
    /// Every sample, by series.
    pub book: SampleBook,
    pub table: LatencyTable,
    pub budgets: Option<Budgets>,
    pub budget_source: BudgetSource,
    /// Where a damaged file stopped being readable.
    pub truncated: Option<String>,
    /// Services recorded with another message layout than this build's (an older
    /// record): not read.
    pub foreign: Vec<String>,
}

/// Profiles a recorded file against its attached budgets.
pub fn profile(path: &Path) -> Result<ProfileReport, ProfileError> {
    profile_with(path, &ProfileOptions::default())
}

pub fn profile_with(path: &Path, opts: &ProfileOptions) -> Result<ProfileReport, ProfileError> {
    let file = RecordFile::open(path)?;
    profile_file(&file, opts)
}

/// Services whose output latency is measured, in report order.
const LATENCY_SERVICES: [&str; 5] = [
    s::POINT_CLOUD,
    s::LOCAL_MAP,
    s::GLOBAL_MAP,
    s::GLOBAL_MAP_CHANGES,
    s::CONTROLLER_BAND,
];

/// The samples of the file, gathered in one pass.
#[derive(Default)]
struct Collected {
    book: SampleBook,
    /// The last tick the supervisor acted on (its newest acknowledgement).
    last_acted: Option<u64>,
    buf: AlignedBuf,
}

impl Collected {
    /// Adds what one recorded payload of `topic` says.
    fn add(&mut self, topic: &str, data: &[u8]) {
        if data.len() < size_of::<Header>() {
            return;
        }
        self.buf.set(data);
        match topic {
            s::TICK_DONE => {
                if let Some(d) = self.buf.view::<TickDone>() {
                    self.book.record_done(d);
                    if d.node == NodeKind::Supervisor.code() && d.status == StageStatus::Done as u32
                    {
                        let t = d.header.tick;
                        self.last_acted = Some(self.last_acted.map_or(t, |l| l.max(t)));
                    }
                }
            }
            s::TRAJECTORY => {
                if let Some(t) = self.buf.view::<Trajectory>() {
                    self.book.record_trajectory(&t.header);
                }
            }
            s::PLAN_RESPONSE => {
                if let Some(r) = self.buf.view::<PlanResponse>() {
                    self.book.record_plan(r);
                }
            }
            s::TICK => {
                if let Some(t) = self.buf.view::<Tick>() {
                    self.book.record_tick(t);
                }
            }
            _ => {}
        }
        if LATENCY_SERVICES.contains(&topic) {
            let tick_wall = u64_at(data, TICK_WALL_AT);
            let published = u64_at(data, PUBLISH_WALL_AT);
            if tick_wall != 0 && published >= tick_wall {
                let tick = u64_at(data, TICK_AT);
                let name = format!("latency {topic}");
                self.book.record(&name, tick, published - tick_wall);
            }
        }
    }
}

/// The attached `budgets.toml`, if the record carries one.
fn attached_budgets(file: &RecordFile) -> Result<Option<Budgets>, ProfileError> {
    let Ok(attachments) = file.attachments() else {
        return Ok(None);
    };
    let Some(a) = attachments.iter().find(|a| a.name == BUDGETS_ATTACHMENT) else {
        return Ok(None);
    };
    let text = String::from_utf8_lossy(&a.data);
    let named = format!(
        "{} (attachment {BUDGETS_ATTACHMENT})",
        file.path().display()
    );
    Ok(Some(aisle_config::parse::<Budgets>(
        Path::new(&named),
        &text,
    )?))
}

pub fn profile_file(
    file: &RecordFile,
    opts: &ProfileOptions,
) -> Result<ProfileReport, ProfileError> {
    let (budgets, budget_source) = match &opts.budgets {
        Some(b) => (Some(b.clone()), BudgetSource::Given),
        None => match attached_budgets(file)? {
            Some(b) => (Some(b), BudgetSource::Attached),
            None => (None, BudgetSource::None),
        },
    };
    let mut collected = Collected::default();
    let mut truncated = None;
    // Whether each channel has this build's layout (read only if so).
    let mut ours = std::collections::BTreeMap::new();
    let mut foreign = Vec::new();
    for m in file.raw_messages() {
        match m {
            Ok(m) => {
                let c = &m.channel;
                let read = *ours.entry(c.id).or_insert_with(|| {
                    let ok = crate::replay::check_channel(file.path(), c).is_ok();
                    if !ok {
                        foreign.push(c.topic.clone());
                    }
                    ok
                });
                if read {
                    collected.add(c.topic.as_str(), &m.data);
                }
            }
            Err(e) => {
                truncated = Some(e.to_string());
                break;
            }
        }
    }
    // A file cut at a record boundary reads to its end without an error, but it has no
    // summary: it was not finished, so it is as damaged as one cut mid-record.
    if truncated.is_none() && !file.is_finalised() {
        truncated = Some(format!(
            "{} has no summary: the recording was not finished (the file is truncated)",
            file.path().display()
        ));
    }
    let Collected {
        mut book,
        last_acted,
        ..
    } = collected;
    if let Some(last) = last_acted {
        book.end_at(last);
    }
    let table = book.summarise(budgets.as_ref());
    if table.stages.is_empty() && table.tick_release.is_none() {
        return Err(ProfileError::Empty {
            path: file.path().display().to_string(),
        });
    }
    Ok(ProfileReport {
        book,
        table,
        budgets,
        budget_source,
        truncated,
        foreign,
    })
}

fn write_err(path: &Path) -> impl FnOnce(std::io::Error) -> ProfileError + '_ {
    move |source| ProfileError::Write {
        path: path.display().to_string(),
        source,
    }
}

impl ProfileReport {
    /// The figures as a text table (milliseconds), with what they were scored against.
    pub fn table(&self) -> String {
        let mut t = format_table(&self.table);
        let _ = writeln!(
            t,
            "budgets: {}",
            match self.budget_source {
                BudgetSource::Given => "as given",
                BudgetSource::Attached => "the record's budgets.toml",
                BudgetSource::None => "none attached to the record: nothing is scored",
            }
        );
        // The one place the damage is said (the CLI prints this table).
        if let Some(tr) = &self.truncated {
            let _ = writeln!(t, "note: profiled what could be read: {tr}");
        }
        if !self.foreign.is_empty() {
            let _ = writeln!(
                t,
                "note: recorded with another message layout than this build's, not read: {}",
                self.foreign.join(", ")
            );
        }
        t
    }

    /// The table as JSON (the shape of a run report's `latency` and `tick_release`).
    pub fn json(&self) -> String {
        serde_json::to_string_pretty(&self.table).unwrap_or_default()
    }

    pub fn write_json(&self, path: &Path) -> Result<(), ProfileError> {
        std::fs::write(path, self.json()).map_err(write_err(path))
    }

    /// Every sample as CSV (`stage,tick,ms`).
    pub fn write_samples(&self, path: &Path) -> Result<(), ProfileError> {
        let file = std::fs::File::create(path).map_err(write_err(path))?;
        self.book
            .write_csv(std::io::BufWriter::new(file))
            .map_err(write_err(path))
    }

    /// Log-scale histograms (power-of-two buckets from 1 us), one per series.
    pub fn histograms(&self) -> String {
        let mut t = String::new();
        for (name, samples) in self.book.series() {
            let _ = writeln!(t, "{name}");
            let mut buckets = [0usize; 40];
            for &(_, v) in &samples {
                let b = (64 - (v / 1000).leading_zeros()) as usize;
                buckets[b.min(39)] += 1;
            }
            let most = *buckets.iter().max().unwrap_or(&1);
            let first = buckets.iter().position(|&c| c > 0).unwrap_or(0);
            let last = buckets.iter().rposition(|&c| c > 0).unwrap_or(0);
            for (b, &count) in buckets.iter().enumerate().take(last + 1).skip(first) {
                let upper_us = if b == 0 { 1u64 } else { 1u64 << b };
                let bar = (count * 40).div_ceil(most.max(1));
                let _ = writeln!(
                    t,
                    "  < {:>9} ms | {:<40} {}",
                    format!("{:.3}", upper_us as f64 / 1000.0),
                    "#".repeat(bar),
                    count
                );
            }
        }
        t
    }

    pub fn write_svg(&self, path: &Path) -> Result<(), ProfileError> {
        std::fs::write(path, svg::plot(self)?).map_err(write_err(path))
    }
}

#[cfg(test)]
mod tests;
