//! One measurement, two views: the latency figures of a run, computed by the same code
//! whether `aisle run` gathers the samples live (from the messages the supervisor
//! receives) or `aisle profile` reads them back from a record (from the headers).
//!
//! Definitions (stated once, here, and in the README's latency section):
//! - **quantile**: nearest rank. The q-quantile of n samples is the smallest sample
//!   with at least q·n samples at or below it, i.e. the ⌈q·n⌉-th smallest (p99 of 100
//!   samples is the 99th smallest, p99.9 of 100 samples is the largest). Every figure
//!   is a sample that was measured, never an interpolation.
//! - **jitter**: the population standard deviation of the samples.
//! - **miss**: a sample strictly over its stage's budget (`budgets.toml`; `profile`
//!   reads the copy attached to the record).
//! - **tick release** (not scored against any budget): in realtime, the lateness of
//!   each tick's start against the ideal schedule start + k·dt (the schedule anchored
//!   at the earliest start consistent with every tick, so lateness is >= 0), the ticks
//!   released a whole period or more late (overruns) and the tick numbers never seen
//!   (skipped); in lockstep a tick starts when the group finished the previous one, so
//!   only the count (and skipped numbers) are given.
//! - **window**: the ticks the whole pipeline completed, i.e. every tick before the
//!   last one the supervisor acted on (samples of that last tick reach a recorder but
//!   not always the supervisor, which stops the group right after it).
//!
//! What a message contributes (the rules both views apply): a non-idle `TickDone` is a
//! compute sample of its node (the recorder's own acknowledgements are not); a
//! `Trajectory` is an end-to-end sample (publish time - start of its tick); a
//! `PlanResponse` is a `global_planner` sample (its solve time); a `Tick` is a release.
//!
//! Knows the message headers and the budgets; not the bus, the file format or any
//! clock.

mod book;
mod budgets;
mod release;
mod stats;
mod table;

pub use book::{LatencyTable, SampleBook};
pub use budgets::{Budgets, EndToEndBudget, STAGE_ORDER, StageBudgets};
pub use release::TickRelease;
pub use stats::{Summary, nearest_rank};
pub use table::format_table;
