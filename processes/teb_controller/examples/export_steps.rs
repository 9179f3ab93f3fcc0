//! Exports the slowest controller steps of a recorded run as a small record the bench
//! replays (`benches/teb_step.rs`, the `mission_*` cases):
//!
//! ```text
//! cargo run --release -p aisle-teb-controller --example export_steps -- \
//!     run.mcap processes/teb_controller/benches/cases/seed.mcap [--worst 6] [--config config]
//! ```
//!
//! "Slowest" is by the compute time the run recorded (`Trajectory.solve_ns`). Every
//! exported step is first replayed here and must reproduce the recorded trajectory bit
//! for bit, or the export fails: a case that is not the mission's step would measure
//! something else. Prints each step's recorded and replayed time and its SCP iterations.
//!
//! `--evaluate` instead replays every step of the record from the state the mission had
//! (open loop: this build's controller on the recorded inputs) and prints the step
//! times (p50, p99, max; each step's time is the least of 5 runs, so the machine's
//! noise stays out), the subproblems, the band's poses before and after, and each
//! step's cost against that of its band with the SCP run on to convergence on the same
//! problem: how a controller change moves the tail and how far from the local optimum
//! its steps stop, on the mission's own steps. Writes nothing.

#[path = "../benches/support/step_cases.rs"]
mod step_cases;

use std::path::PathBuf;
use std::time::Instant;

use aisle_teb_controller::TebConfig;
use aisle_teb_controller::case::{RecordedStep, reproduces};
use aisle_tools::latency::nearest_rank;
use aisle_tools::{RecordWriter, WriterOptions};
use step_cases::{AlignedStep, StepMessages, converged_cost, steps_in};

struct Args {
    record: PathBuf,
    out: Option<PathBuf>,
    evaluate: bool,
    worst: usize,
    config: PathBuf,
}

fn parse() -> Result<Args, String> {
    let usage = "usage: export_steps RECORD (OUT.mcap [--worst N] | --evaluate) [--config DIR]";
    let mut pos = Vec::new();
    let (mut worst, mut config, mut evaluate) = (6, PathBuf::from("config"), false);
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--worst" => {
                let v = it.next().ok_or(usage)?;
                worst = v
                    .parse()
                    .map_err(|_| format!("--worst {v:?} is not a count"))?;
            }
            "--config" => config = it.next().ok_or(usage)?.into(),
            "--evaluate" => evaluate = true,
            _ if a.starts_with("--") => return Err(format!("unknown option {a}; {usage}")),
            _ => pos.push(PathBuf::from(a)),
        }
    }
    let mut pos = pos.into_iter();
    let (Some(record), out, None) = (pos.next(), pos.next(), pos.next()) else {
        return Err(usage.to_string());
    };
    if out.is_some() == evaluate {
        return Err(usage.to_string());
    }
    Ok(Args {
        record,
        out,
        evaluate,
        worst,
        config,
    })
}

fn recorded_ns(s: &StepMessages) -> Result<u64, String> {
    Ok(AlignedStep::of(s).trajectory()?.solve_ns)
}

/// Replays `s`; its wall time in ms, SCP iterations and cost, or why it is not the run's
/// step.
fn replay(cfg: &TebConfig, s: &StepMessages) -> Result<(f64, usize, f64), String> {
    let aligned = AlignedStep::of(s);
    let mut step = RecordedStep::new(cfg.clone(), &aligned.inputs()?)?;
    let start = Instant::now();
    let out = step.step().map_err(|e| e.to_string())?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    if !reproduces(out, aligned.trajectory()?) {
        return Err("the replayed step differs from the recorded trajectory".into());
    }
    Ok((ms, out.iterations, out.cost))
}

fn write(out: &std::path::Path, steps: &[&StepMessages]) -> Result<(), String> {
    let mut all: Vec<&aisle_tools::FileMessage> = Vec::new();
    for s in steps {
        all.extend([&s.tick, &s.goal, &s.state, &s.map, &s.trajectory]);
        all.extend(s.band.as_ref());
    }
    all.sort_by_key(|m| (m.log_time, m.channel.topic.clone(), m.sequence));
    all.dedup_by(|a, b| a.channel.topic == b.channel.topic && a.sequence == b.sequence);
    let file = std::fs::File::create(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut w = RecordWriter::new(std::io::BufWriter::new(file), WriterOptions::default())
        .map_err(|e| e.to_string())?;
    for m in all {
        w.write_raw(&m.channel.topic, m.log_time, &m.data)
            .map_err(|e| e.to_string())?;
    }
    w.finish().map_err(|e| e.to_string())?;
    Ok(())
}

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("export_steps: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

fn run() -> Result<(), String> {
    let args = parse()?;
    let teb = args.config.join("teb.toml");
    let cfg: TebConfig = aisle_config::load(&teb).map_err(|e| e.to_string())?;
    let steps = steps_in(&args.record)?;
    if args.evaluate {
        return evaluate(&cfg, &steps);
    }
    let mut timed = Vec::new();
    for s in &steps {
        timed.push((recorded_ns(s)?, s));
    }
    timed.sort_by_key(|(ns, _)| std::cmp::Reverse(*ns));
    timed.truncate(args.worst);
    println!(
        "{} controller steps in {}",
        steps.len(),
        args.record.display()
    );
    for (ns, s) in &timed {
        let (ms, iterations, cost) = replay(&cfg, s).map_err(|e| {
            format!(
                "step at {:.1} s: {e}",
                s.trajectory.publish_time as f64 * 1e-9
            )
        })?;
        println!(
            "  t {:7.1} s  recorded {:6.2} ms  replayed {:6.2} ms  {} SCP iterations  cost {:.4}",
            s.trajectory.publish_time as f64 * 1e-9,
            *ns as f64 * 1e-6,
            ms,
            iterations,
            cost
        );
    }
    let chosen: Vec<&StepMessages> = timed.iter().map(|(_, s)| *s).collect();
    let out = args.out.ok_or("no output file")?;
    write(&out, &chosen)?;
    println!("wrote {} steps to {}", chosen.len(), out.display());
    Ok(())
}

/// One evaluated step: its time (ns), publish time (ns), subproblems, cost / converged
/// cost, warm poses and poses.
type Evaluated = (u64, u64, usize, f64, usize, usize);

fn print_row(&(ns, t, iterations, ratio, warm, poses): &Evaluated) {
    println!(
        "  t {:7.1} s  {:6.2} ms  {iterations:2} subproblems  cost / converged {ratio:.4}  \
         poses {warm} -> {poses}",
        t as f64 * 1e-9,
        ns as f64 * 1e-6
    );
}

/// Runs of each step in `--evaluate`; its time is the least of them.
const REPEATS: usize = 5;

fn evaluate(cfg: &TebConfig, steps: &[StepMessages]) -> Result<(), String> {
    let (mut times, mut ratios, mut subproblems) = (Vec::new(), Vec::new(), 0);
    let mut rows = Vec::new();
    for s in steps {
        let aligned = AlignedStep::of(s);
        let inputs = aligned.inputs()?;
        let mut step = RecordedStep::new(cfg.clone(), &inputs)?;
        let warm = step.warm_poses();
        // The least of a few runs of the same step: the rest is the machine's noise.
        let mut ns = u64::MAX;
        for _ in 1..REPEATS {
            let start = Instant::now();
            step.step().map_err(|e| e.to_string())?;
            ns = ns.min(start.elapsed().as_nanos() as u64);
            step.reset().map_err(|e| e.to_string())?;
        }
        let start = Instant::now();
        let out = step.step().map_err(|e| e.to_string())?;
        let ns = ns.min(start.elapsed().as_nanos() as u64);
        times.push(ns);
        subproblems += out.iterations;
        let mut ratio = f64::NAN;
        if let Some((cost, converged)) = converged_cost(cfg, &inputs)? {
            ratio = cost / converged;
            ratios.push(ratio);
        }
        let poses = out.poses.len();
        rows.push((
            ns,
            s.trajectory.publish_time,
            out.iterations,
            ratio,
            warm,
            poses,
        ));
    }
    // The steps that stopped farthest above their optimum, and how many passed 1 %.
    let mut far: Vec<_> = rows.iter().filter(|r| r.3 > 1.01).collect();
    far.sort_by(|a, b| b.3.total_cmp(&a.3));
    println!("steps more than 1 % above their optimum: {}", far.len());
    far.iter().take(10).for_each(|r| print_row(r));
    rows.sort_by_key(|r| std::cmp::Reverse(r.0));
    println!("the slowest steps:");
    rows.iter().take(10).for_each(print_row);
    // The project's one quantile (nearest rank), on ns and on ratios in millionths.
    times.sort_unstable();
    let mut ppm: Vec<u64> = ratios.iter().map(|r| (r * 1e6).round() as u64).collect();
    ppm.sort_unstable();
    let ms = |q: f64| nearest_rank(&times, q) as f64 * 1e-6;
    let ratio = |q: f64| nearest_rank(&ppm, q) as f64 * 1e-6;
    println!(
        "{} steps: time p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms; {} subproblems",
        times.len(),
        ms(0.5),
        ms(0.99),
        ms(1.0),
        subproblems
    );
    println!(
        "cost / converged cost over {} optimised steps: p50 {:.4}, p90 {:.4}, max {:.4}, min {:.4}",
        ppm.len(),
        ratio(0.5),
        ratio(0.9),
        ratio(1.0),
        ratio(0.0)
    );
    Ok(())
}
