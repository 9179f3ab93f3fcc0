//! Replays a record's plan requests with this build's planner, each on the global map the
//! mission had when it asked (the newest full map and changes stamped at or before the
//! request), through
//! the planner's own stage (`PlannerStage` on an in-memory `Io`), and prints each
//! request's recorded and replayed outcome side by side:
//!
//! ```text
//! cargo run --release -p aisle-global-planner --example replay_requests -- \
//!     run.mcap [--config config] [--only ID] [--repeat N] [--start]
//! ```
//!
//! What a planner change does to the requests a mission really made (a sweep's failure
//! record, say), without running the mission again. Writes nothing. `--repeat N` replays
//! the whole record N times, each time through a new stage (so every run pays the
//! first-use costs the mission pays), prints only the last run's table, each request's
//! fastest and median time over the runs, and a digest of every returned path's poses
//! (bit for bit: the same digest means the same paths), for profiling and timing.
//! `--start` starts each stage on the record's first map, as the node starts (its map
//! tables built and its buffers made resident before the first request).

use std::hash::{DefaultHasher, Hash, Hasher};
use std::mem::offset_of;
use std::path::PathBuf;

use aisle_global_planner::node::PlannerStage;
use aisle_messages::{
    GlobalGrid, Header, MapChanges, Message, PlanRequest, PlanResponse, PlanStatus, TickMode,
    topics,
};
use aisle_node::testing::MemIo;
use aisle_node::{RunContext, Stage};
use aisle_tools::aligned::AlignedBuf;
use aisle_tools::{FileMessage, RecordFile};

fn stamp(m: &FileMessage) -> u64 {
    let at = offset_of!(Header, stamp_ns);
    m.data
        .get(at..at + 8)
        .and_then(|b| b.try_into().ok())
        .map_or(0, u64::from_le_bytes)
}

fn copy_into<M: Message + Copy>(dst: &mut M, m: &FileMessage) -> Result<(), String> {
    let buf = AlignedBuf::from_bytes(&m.data);
    let src = buf
        .view::<M>()
        .ok_or_else(|| format!("a payload is not a {}", M::TYPE_NAME))?;
    *dst = *src;
    Ok(())
}

fn status_name(s: u32) -> String {
    PlanStatus::from_u32(s).map_or(format!("status {s}"), |s| format!("{s:?}"))
}

fn main() -> Result<(), String> {
    let usage = "usage: replay_requests RECORD [--config DIR] [--only ID] [--repeat N] [--start]";
    let mut args = std::env::args().skip(1);
    let (mut record, mut config, mut only) = (None, PathBuf::from("config"), None);
    let (mut repeat, mut start) = (1usize, false);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--config" => config = args.next().ok_or(usage)?.into(),
            "--start" => start = true,
            "--repeat" => {
                let v = args.next().ok_or(usage)?;
                repeat = v.parse().map_err(|_| format!("--repeat {v:?}"))?;
            }
            "--only" => {
                let v = args.next().ok_or(usage)?;
                only = Some(v.parse::<u64>().map_err(|_| format!("--only {v:?}"))?);
            }
            _ if a.starts_with("--") => return Err(format!("unknown option {a}; {usage}")),
            _ => record = Some(PathBuf::from(a)),
        }
    }
    let record = record.ok_or(usage)?;
    let file = RecordFile::open(&record).map_err(|e| e.to_string())?;
    let (mut maps, mut requests, mut responses) = (Vec::new(), Vec::new(), Vec::new());
    let mut changes = Vec::new();
    for m in file.raw_messages() {
        let m = m.map_err(|e| e.to_string())?;
        match m.channel.topic.as_str() {
            t if t == topics::GLOBAL_MAP.name => maps.push(m),
            t if t == topics::GLOBAL_MAP_CHANGES.name => changes.push(m),
            t if t == topics::PLAN_REQUEST.name => requests.push(m),
            t if t == topics::PLAN_RESPONSE.name => responses.push(m),
            _ => {}
        }
    }
    let mut times: Vec<Vec<f64>> = Vec::new();
    let mut digest = 0;
    for run in 0..repeat {
        let mut stage = PlannerStage::new(&config).map_err(|e| e.to_string())?;
        if start {
            start_stage(&mut stage, maps.first().ok_or("no map in the record")?)?;
        }
        let print = run + 1 == repeat;
        if print {
            println!(
                "request  t [s]  recorded (status, expansions)  replayed (status, expansions, length, ms)"
            );
        }
        let mut hasher = DefaultHasher::new();
        let mut k = 0;
        for req_msg in &requests {
            let buf = AlignedBuf::from_bytes(&req_msg.data);
            let req = *buf
                .view::<PlanRequest>()
                .ok_or("a payload is not a PlanRequest")?;
            if only.is_some_and(|id| id != req.request_id) {
                continue;
            }
            let ms = replay_one(
                &mut stage,
                &req,
                req_msg,
                (&maps, &changes),
                &responses,
                &mut hasher,
                print,
            )?;
            if times.len() == k {
                times.push(Vec::new());
            }
            times[k].push(ms);
            k += 1;
        }
        let d = hasher.finish();
        if run > 0 && d != digest {
            return Err(format!("run {run} returned other paths than run 0"));
        }
        digest = d;
    }
    if repeat > 1 {
        for (k, t) in times.iter_mut().enumerate() {
            t.sort_by(f64::total_cmp);
            println!(
                "request #{}: fastest {:.2} ms, median {:.2} ms over {repeat} runs",
                k + 1,
                t[0],
                t[t.len() / 2]
            );
        }
    }
    println!("paths digest {digest:016x}");
    Ok(())
}

/// Starts `stage` on `map` as the node runtime does.
fn start_stage(stage: &mut PlannerStage, map: &FileMessage) -> Result<(), String> {
    let io = MemIo::new();
    let mut err = Ok(());
    io.push(topics::GLOBAL_MAP, |m: &mut GlobalGrid| {
        err = copy_into(m, map)
    });
    err?;
    let ctx = RunContext {
        mode: TickMode::Lockstep,
        seed: 0,
        restarted: false,
    };
    stage.start(&io, &ctx).map_err(|e| e.to_string())
}

/// Replays one request through `stage` on the map it had; hashes the response's status
/// and poses into `hasher`, prints the row if `print`; returns its time in ms.
fn replay_one(
    stage: &mut PlannerStage,
    req: &PlanRequest,
    req_msg: &FileMessage,
    (maps, changes): (&[FileMessage], &[FileMessage]),
    responses: &[FileMessage],
    hasher: &mut DefaultHasher,
    print: bool,
) -> Result<f64, String> {
    let t = stamp(req_msg);
    let pose = |p: aisle_messages::Pose2Msg| format!("({:.3}, {:.3}, {:.4})", p.x, p.y, p.theta);
    if print {
        println!(
            "        start {} goal {} footprint {:.3} x {:.3} margin {:.3} detections {} dock {}",
            pose(req.start),
            pose(req.goal),
            req.footprint_length,
            req.footprint_width,
            req.margin,
            req.use_detections,
            req.dock,
        );
    }
    let map = maps
        .iter()
        .rev()
        .find(|m| stamp(m) <= t)
        .ok_or("no map before a request")?;
    let io = MemIo::new();
    let mut err = Ok(());
    io.push(topics::GLOBAL_MAP, |m: &mut GlobalGrid| {
        err = copy_into(m, map)
    });
    err?;
    if let Some(c) = changes.iter().rev().find(|m| stamp(m) <= t) {
        let mut copied = Ok(());
        io.push(topics::GLOBAL_MAP_CHANGES, |m: &mut MapChanges| {
            copied = copy_into(m, c)
        });
        copied?;
    }
    stage.process(req, &io).map_err(|e| e.to_string())?;
    let recorded = responses.iter().find_map(|r| {
        let b = AlignedBuf::from_bytes(&r.data);
        let r = b.view::<PlanResponse>()?;
        (r.request_id == req.request_id).then_some((r.status, r.expansions))
    });
    let replayed = io
        .published(topics::PLAN_RESPONSE, 0, |r: &PlanResponse| {
            // Not the expansions: a change that finds the same paths with less work
            // keeps the digest.
            (r.status, r.path_length.to_bits()).hash(hasher);
            (r.split, r.straight, r.len).hash(hasher);
            for p in &r.poses[..r.len as usize] {
                (p.x.to_bits(), p.y.to_bits(), p.theta.to_bits(), p.direction).hash(hasher);
            }
            (
                r.status,
                r.expansions,
                r.path_length,
                r.solve_ns as f64 / 1e6,
            )
        })
        .ok_or("no response")?;
    if print {
        println!(
            "{:>7} {:>6.1}  {:<30} {} {} {:.2} m {:.1} ms",
            req.request_id,
            t as f64 / 1e9,
            recorded.map_or("-".into(), |(s, e)| format!("{} {e}", status_name(s))),
            status_name(replayed.0),
            replayed.1,
            replayed.2,
            replayed.3,
        );
    }
    Ok(replayed.3)
}
