//! `aisle sweep`: N generated scenarios ([`crate::scenario`]) spread round-robin over
//! the chosen families, each run by this same binary as `aisle run --quiet --report`
//! in its own instance, J at a time, and once more as its oracle (every movable body
//! the mission does not name made static) to tell infeasible from failed. A failure of
//! a feasible scenario (or an unclean failure of an infeasible one) is run again with
//! `--record` and drawn. Writes `sweep.json` and `sweep.md` and prints the table.
//!
//! - [`runner`]: one child run, its timeout and cleanup, its outcome.
//! - [`stats`]: per scenario and per family figures, the Wilson interval.
//! - [`table`]: the markdown.
//!
//! Knows how to run scenarios, not how they are made or how a run works inside.

pub mod runner;
pub mod stats;
pub mod table;

use crate::scenario::{self, Family, GenerateOptions, ground::Ground};
use runner::{Outcome, RunSpec, RunSummary};
use serde::Serialize;
use stats::{FamilyStats, ScenarioResult, family_stats};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
pub struct SweepOptions {
    pub count: usize,
    pub seed: u64,
    pub jobs: usize,
    pub families: Vec<Family>,
    pub out: PathBuf,
    pub base: PathBuf,
    pub timeout: Duration,
}

/// `sweep.json`.
#[derive(Debug, Serialize)]
pub struct SweepReport {
    pub seed: u64,
    pub count: usize,
    pub jobs: usize,
    pub families: Vec<String>,
    pub wall_time_s: f64,
    /// Every feasible scenario succeeded with 0 collisions, every infeasible one failed
    /// cleanly, no run was an error.
    pub all_as_expected: bool,
    pub per_family: Vec<FamilyStats>,
    pub all: FamilyStats,
    pub scenarios: Vec<ScenarioResult>,
}

/// The seed of scenario `i` of a sweep seeded `seed` (what `aisle scenario generate
/// --seed` takes to make it again).
pub fn scenario_seed(seed: u64, i: usize) -> u64 {
    seed.wrapping_mul(1_000_000).wrapping_add(i as u64)
}

/// Runs the sweep. Err: it could not run at all (base config, output directory).
pub fn sweep(opts: &SweepOptions) -> Result<SweepReport, String> {
    let started = Instant::now();
    let ground = Ground::load(&opts.base).map_err(|e| format!("the base config: {e}"))?;
    if let Some(why) = opts.families.iter().find_map(|&f| ground.unfit_for(f)) {
        return Err(why);
    }
    let exe = std::env::current_exe().map_err(|e| format!("cannot find this executable: {e}"))?;
    for sub in ["scenarios", "oracles", "runs", "failures"] {
        let d = opts.out.join(sub);
        std::fs::create_dir_all(&d).map_err(|e| format!("{}: {e}", d.display()))?;
    }
    let work: Vec<(usize, Family)> = (0..opts.count)
        .map(|i| (i, opts.families[i % opts.families.len()]))
        .collect();
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel();
    let mut results: Vec<ScenarioResult> = Vec::with_capacity(opts.count);
    std::thread::scope(|s| {
        for _ in 0..opts.jobs.max(1) {
            let tx = tx.clone();
            let (work, next, ground, exe) = (&work, &next, &ground, &exe);
            s.spawn(move || {
                while let Some(&(i, family)) = work.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let r = scenario_run(opts, ground, exe, i, family);
                    if tx.send(r).is_err() {
                        return;
                    }
                }
            });
        }
        drop(tx);
        let progress = Progress::new(opts.count);
        for r in rx {
            progress.done(&r);
            results.push(r);
        }
        progress.finish();
    });
    results.sort_by(|a, b| a.id.cmp(&b.id));
    let per_family: Vec<FamilyStats> = opts
        .families
        .iter()
        .map(|f| {
            let of: Vec<&ScenarioResult> =
                results.iter().filter(|r| r.family == f.name()).collect();
            family_stats(f.name(), &of)
        })
        .collect();
    let all = family_stats("all", &results.iter().collect::<Vec<_>>());
    Ok(SweepReport {
        seed: opts.seed,
        count: opts.count,
        jobs: opts.jobs,
        families: opts.families.iter().map(|f| f.name().to_string()).collect(),
        wall_time_s: started.elapsed().as_secs_f64(),
        all_as_expected: results.iter().all(ScenarioResult::as_expected),
        per_family,
        all,
        scenarios: results,
    })
}

/// Writes `sweep.json` and `sweep.md` into the output directory; returns the markdown.
pub fn write(opts: &SweepOptions, report: &SweepReport) -> Result<String, String> {
    let md = table::markdown(&report.per_family, &report.all, &report.scenarios);
    let md = format!(
        "Sweep: {} scenarios, seed {}, {} jobs, {:.0} s wall.\n\n{md}",
        report.count, report.seed, report.jobs, report.wall_time_s
    );
    let json = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
    for (name, text) in [("sweep.json", &json), ("sweep.md", &md)] {
        let p = opts.out.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(md)
}

/// Generate, run, run the oracle, and record a failure: one scenario, start to end.
fn scenario_run(
    opts: &SweepOptions,
    ground: &Ground,
    exe: &Path,
    i: usize,
    family: Family,
) -> ScenarioResult {
    let seed = scenario_seed(opts.seed, i);
    let id = format!("{i:03}-{}", family.name());
    let dir = opts.out.join("scenarios").join(&id);
    let mut r = ScenarioResult {
        id: id.clone(),
        family: family.name().to_string(),
        seed,
        config_dir: dir.clone(),
        varied: Vec::new(),
        feasible: false,
        outcome: Outcome::Error,
        clean_failure: false,
        reason: None,
        collisions: 0,
        time_to_goal_s: None,
        path_length_m: None,
        oracle_path_length_m: None,
        replans: None,
        run: None,
        oracle: None,
        record: None,
        picture: None,
    };
    let spec = GenerateOptions {
        seed,
        family,
        out: dir.clone(),
        base: opts.base.clone(),
    };
    let oracle_dir = opts.out.join("oracles").join(&id);
    let made = scenario::generate_from(ground, &spec)
        .and_then(|g| scenario::write::write_oracle(&dir, &oracle_dir).map(|_| g));
    match made {
        Ok(g) => r.varied = g.varied,
        Err(e) => {
            r.reason = Some(format!("generate: {e}"));
            return r;
        }
    }
    let runs = opts.out.join("runs");
    let go = |config: &Path, name: &str, record: Option<&Path>| {
        runner::run(&RunSpec {
            exe,
            config_dir: config,
            report: &runs.join(format!("{name}.json")),
            log: &runs.join(format!("{name}.log")),
            record,
            timeout: opts.timeout,
        })
    };
    let run = go(&dir, &id, None);
    let oracle = go(&oracle_dir, &format!("{id}-oracle"), None);
    classify(&mut r, run, oracle);
    let wants_picture = r.outcome == Outcome::Failure && (r.feasible || !r.clean_failure);
    if wants_picture {
        let mcap = opts.out.join("failures").join(format!("{id}.mcap"));
        let png = mcap.with_extension("png");
        let again = go(&dir, &format!("{id}-record"), Some(&mcap));
        if again.outcome != Outcome::Error {
            let ro = aisle_tools::render::RenderOptions {
                pixels_per_metre: 25.0,
                band_every: 15,
                driven: true,
            };
            if aisle_tools::render::render(&mcap, &png, &ro).is_ok() {
                r.picture = Some(png);
            }
            r.record = Some(mcap);
        }
    }
    r
}

/// Fills the verdict of a scenario from its run and its oracle's.
fn classify(r: &mut ScenarioResult, run: RunSummary, oracle: RunSummary) {
    r.outcome = run.outcome;
    r.feasible = run.outcome == Outcome::Success || oracle.outcome == Outcome::Success;
    r.clean_failure =
        run.outcome == Outcome::Failure && run.collisions == 0 && run.reason.is_some();
    r.reason = run.reason.clone();
    r.collisions = run.collisions;
    if run.outcome == Outcome::Success {
        r.time_to_goal_s = run.sim_time_s;
    }
    r.path_length_m = run.path_length_m;
    r.replans = run.replans;
    if oracle.outcome == Outcome::Success {
        r.oracle_path_length_m = oracle.path_length_m;
    }
    r.run = Some(run);
    r.oracle = Some(oracle);
}

/// A bar on a terminal, a line per scenario otherwise.
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    total: usize,
    done: AtomicUsize,
}

impl Progress {
    fn new(total: usize) -> Progress {
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new(total as u64);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} scenarios, {elapsed} elapsed, about {eta} left  {msg}",
            ) {
                b.set_style(style);
            }
            b
        });
        Progress {
            bar,
            total,
            done: AtomicUsize::new(0),
        }
    }

    fn done(&self, r: &ScenarioResult) {
        let n = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        let line = format!(
            "{} {:?}{}{}",
            r.id,
            r.outcome,
            if r.feasible { "" } else { " (infeasible)" },
            r.reason
                .as_deref()
                .map(|s| format!(": {s}"))
                .unwrap_or_default()
        );
        match &self.bar {
            Some(b) => {
                b.inc(1);
                b.set_message(line);
            }
            None => eprintln!("[{n}/{}] {line}", self.total),
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
