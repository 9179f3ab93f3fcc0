//! Messages across the link: hosts `a` and `b` in one process (two iceoryx2 instances,
//! two Zenoh sessions on the loopback interface, `aisle_link::testing`); a message
//! published on `a` is timed until `b`'s subscriber is woken with it, one in flight:
//! - `point_cloud_a_to_b`: the lidar's `PointCloud` with the seed pattern's 31 x 1201
//!   points filled (447 KB of points in a message of 1.57 MB capacity; the link
//!   carries the points, `aisle_link::trimmed`), so criterion's throughput is the
//!   link's for back-to-back clouds;
//! - `global_map_a_to_b`: the seed's 200 x 300-cell global map in a `GlobalGrid` of
//!   16 MiB capacity;
//! - `robot_state_a_to_b`: the 128-byte `RobotState`, the link's latency alone.
//!
//! After criterion's own figures each case prints its per-sample distribution (every
//! timed sample, warm-up included; nearest rank as `aisle_tools::latency`): p50, p99,
//! max, messages per second and bytes per second (of the bytes the message uses).

use aisle_bus::{Stamp, Topic, WaitOutcome};
use aisle_geometry::GridView;
use aisle_link::testing::LoopbackPair;
use aisle_messages::{GlobalGrid, GridMessage, Message, PointCloud, RobotState, topics};
use aisle_tools::latency::nearest_rank;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::sync::LazyLock;
use std::time::{Duration, Instant};

/// The seed lidar pattern (`config/lidar.toml`): rows x columns.
const ROWS: u32 = 31;
const COLS: u32 = 1201;

fn fill_cloud(m: &mut PointCloud, k: u64) {
    m.rows = ROWS;
    m.cols = COLS;
    let n = (ROWS * COLS) as usize;
    for (i, p) in m.points[..n].iter_mut().enumerate() {
        let a = i as f32 * 1e-3 + k as f32;
        *p = [a, -a, 0.5];
    }
}

/// The seed's global map (`config/mapper.toml`): 20 x 30 m at 10 cells/m.
fn fill_map(m: &mut GlobalGrid, k: u64) {
    const W: usize = 200;
    const H: usize = 300;
    static CELLS: LazyLock<Vec<u8>> =
        LazyLock::new(|| (0..W * H).map(|i| (i % 101) as u8).collect());
    let map = GridView::new(-5.0, -10.0, 0.1, W, H, &CELLS).expect("a valid map");
    m.write(0, k, &map).expect("the seed's map fits");
}

fn fill_state(m: &mut RobotState, k: u64) {
    m.pose.x = k as f64 * 1e-3;
    m.active_goal_id = k;
}

/// Times `topic` from `a` to `b` as criterion case `name`, then prints the
/// distribution.
fn across<M: Message>(c: &mut Criterion, name: &str, topic: Topic<M>, fill: fn(&mut M, u64)) {
    let pair = LoopbackPair::new(name, &[topic.name]);
    let mut out = pair.a.publisher(topic).expect("publisher on a");
    let inp = pair.b.subscriber(topic).expect("subscriber on b");
    // Until the link has seen both sides a sample may find nobody on the other one.
    let ready = (0..200).any(|_| {
        let seq = out.publish(Stamp::default(), |m| fill(m, 0)).unwrap();
        inp.wait_for(Duration::from_millis(50), |m| m.header().seq == seq, || {})
            .is_ok_and(|(o, _)| o == WaitOutcome::Matched)
    });
    assert!(ready, "no {name} sample crossed within 10 s");
    // One exchange: publish on a, wait on b for that very sample.
    let mut k = 0u64;
    let mut samples: Vec<u64> = Vec::new();
    let mut exchange = || -> Duration {
        k += 1;
        let start = Instant::now();
        let seq = out
            .publish(Stamp::default(), |m| fill(m, k))
            .expect("publish");
        let (outcome, _) = inp
            .wait_for(Duration::from_secs(2), |m| m.header().seq == seq, || {})
            .expect("receive");
        assert_eq!(outcome, WaitOutcome::Matched, "{name} {seq} did not cross");
        start.elapsed()
    };
    let size = {
        let mut m = aisle_messages::zeroed_box::<M>();
        fill(&mut m, 0);
        m.used_len()
    };
    let mut g = c.benchmark_group("link");
    g.throughput(Throughput::Bytes(size as u64));
    g.sample_size(50);
    g.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let d = exchange();
                samples.push(d.as_nanos() as u64);
                total += d;
            }
            total
        })
    });
    g.finish();
    if samples.is_empty() {
        return;
    }
    samples.sort_unstable();
    let ms = |ns: u64| ns as f64 * 1e-6;
    let mean = samples.iter().sum::<u64>() as f64 / samples.len() as f64;
    println!(
        "link/{name}: {} samples of {size} B, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms; \
         {:.0} messages/s, {:.1} MB/s",
        samples.len(),
        ms(nearest_rank(&samples, 0.5)),
        ms(nearest_rank(&samples, 0.99)),
        ms(*samples.last().unwrap()),
        1e9 / mean,
        size as f64 / mean * 1e3,
    );
}

/// CPU time this process has used (all threads), seconds.
fn process_cpu() -> f64 {
    // SAFETY: getrusage writes only into the zeroed struct it is given.
    let u = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_SELF, &mut u);
        u
    };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(u.ru_utime) + secs(u.ru_stime)
}

/// What two idle links (one per host) cost: CPU time over 3 s with nothing to carry.
fn idle_cost() {
    let pair = LoopbackPair::new("idle", &[topics::ROBOT_STATE.name]);
    std::thread::sleep(Duration::from_millis(500));
    let (t0, c0) = (Instant::now(), process_cpu());
    std::thread::sleep(Duration::from_secs(3));
    let share = (process_cpu() - c0) / t0.elapsed().as_secs_f64();
    println!(
        "link/idle: two idle links use {:.1} % of one core together",
        100.0 * share
    );
    drop(pair);
}

fn link(c: &mut Criterion) {
    idle_cost();
    across(c, "point_cloud_a_to_b", topics::POINT_CLOUD, fill_cloud);
    across(c, "global_map_a_to_b", topics::GLOBAL_MAP, fill_map);
    across(c, "robot_state_a_to_b", topics::ROBOT_STATE, fill_state);
}

criterion_group!(benches, link);
criterion_main!(benches);
