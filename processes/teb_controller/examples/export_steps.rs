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

#[path = "../benches/support/step_cases.rs"]
mod step_cases;

use std::path::PathBuf;
use std::time::Instant;

use aisle_teb_controller::TebConfig;
use aisle_teb_controller::case::{RecordedStep, reproduces};
use aisle_tools::{RecordWriter, WriterOptions};
use step_cases::{AlignedStep, StepMessages, steps_in};

struct Args {
    record: PathBuf,
    out: PathBuf,
    worst: usize,
    config: PathBuf,
}

fn parse() -> Result<Args, String> {
    let usage = "usage: export_steps RECORD OUT.mcap [--worst N] [--config DIR]";
    let mut pos = Vec::new();
    let (mut worst, mut config) = (6, PathBuf::from("config"));
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
            _ if a.starts_with("--") => return Err(format!("unknown option {a}; {usage}")),
            _ => pos.push(PathBuf::from(a)),
        }
    }
    let [record, out] = <[PathBuf; 2]>::try_from(pos).map_err(|_| usage.to_string())?;
    Ok(Args {
        record,
        out,
        worst,
        config,
    })
}

fn recorded_ns(s: &StepMessages) -> Result<u64, String> {
    Ok(AlignedStep::of(s).trajectory()?.solve_ns)
}

/// Replays `s`; its wall time in ms and SCP iterations, or why it is not the run's step.
fn replay(cfg: &TebConfig, s: &StepMessages) -> Result<(f64, usize), String> {
    let aligned = AlignedStep::of(s);
    let mut step = RecordedStep::new(cfg.clone(), &aligned.inputs()?)?;
    let start = Instant::now();
    let out = step.step().map_err(|e| e.to_string())?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    if !reproduces(out, aligned.trajectory()?) {
        return Err("the replayed step differs from the recorded trajectory".into());
    }
    Ok((ms, out.iterations))
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
        let (ms, iterations) = replay(&cfg, s).map_err(|e| {
            format!(
                "step at {:.1} s: {e}",
                s.trajectory.publish_time as f64 * 1e-9
            )
        })?;
        println!(
            "  t {:7.1} s  recorded {:6.2} ms  replayed {:6.2} ms  {} SCP iterations",
            s.trajectory.publish_time as f64 * 1e-9,
            *ns as f64 * 1e-6,
            ms,
            iterations
        );
    }
    let chosen: Vec<&StepMessages> = timed.iter().map(|(_, s)| *s).collect();
    write(&args.out, &chosen)?;
    println!("wrote {} steps to {}", chosen.len(), args.out.display());
    Ok(())
}
