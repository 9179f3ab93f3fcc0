//! The point cloud across the link: hosts `a` and `b` in one process (two iceoryx2
//! instances, two Zenoh sessions on the loopback interface, `aisle_link::testing`), the
//! lidar's `PointCloud` published on `a` with the seed pattern's 31 x 1201 points filled
//! (447 KB of points; the message is its fixed 1.57 MB capacity, all of which the link
//! carries), timed until `b`'s subscriber is woken with it. One sample in flight, so
//! criterion's throughput is the link's for back-to-back clouds.
//!
//! After criterion's own figures the bench prints the per-sample distribution (every
//! timed sample, warm-up included; nearest rank as `aisle_tools::latency`): p50, p99,
//! max, clouds per second and bytes per second.

use aisle_bus::{Stamp, WaitOutcome};
use aisle_link::testing::LoopbackPair;
use aisle_messages::{PointCloud, topics};
use aisle_tools::latency::nearest_rank;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The seed lidar pattern (`config/lidar.toml`): rows x columns.
const ROWS: u32 = 31;
const COLS: u32 = 1201;

/// Every timed sample's latency, in nanoseconds.
static SAMPLES: Mutex<Vec<u64>> = Mutex::new(Vec::new());

fn fill(m: &mut PointCloud, k: u64) {
    m.rows = ROWS;
    m.cols = COLS;
    let n = (ROWS * COLS) as usize;
    for (i, p) in m.points[..n].iter_mut().enumerate() {
        let a = i as f32 * 1e-3 + k as f32;
        *p = [a, -a, 0.5];
    }
}

fn cloud_across_link(c: &mut Criterion) {
    let pair = LoopbackPair::new("bench", &[topics::POINT_CLOUD.name]);
    let mut out = pair
        .a
        .publisher(topics::POINT_CLOUD)
        .expect("publisher on a");
    let inp = pair
        .b
        .subscriber(topics::POINT_CLOUD)
        .expect("subscriber on b");
    // Until the link has seen both sides a sample may find nobody on the other one.
    let ready = (0..200).any(|_| {
        let seq = out.publish(Stamp::default(), |m| fill(m, 0)).unwrap();
        inp.wait_for(Duration::from_millis(50), |m| m.header.seq == seq, || {})
            .is_ok_and(|(o, _)| o == WaitOutcome::Matched)
    });
    assert!(ready, "no cloud crossed within 10 s");
    // One exchange: publish on a, wait on b for that very sample.
    let mut k = 0u64;
    let mut exchange = || -> Duration {
        k += 1;
        let start = Instant::now();
        let seq = out
            .publish(Stamp::default(), |m| fill(m, k))
            .expect("publish");
        let (outcome, _) = inp
            .wait_for(Duration::from_secs(2), |m| m.header.seq == seq, || {})
            .expect("receive");
        assert_eq!(outcome, WaitOutcome::Matched, "cloud {seq} did not cross");
        start.elapsed()
    };
    let mut g = c.benchmark_group("link");
    g.throughput(Throughput::Bytes(std::mem::size_of::<PointCloud>() as u64));
    g.sample_size(50);
    g.bench_function("point_cloud_a_to_b", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            let mut book = SAMPLES.lock().unwrap();
            for _ in 0..iters {
                let d = exchange();
                book.push(d.as_nanos() as u64);
                total += d;
            }
            total
        })
    });
    g.finish();
    let mut all = SAMPLES.lock().unwrap().clone();
    if all.is_empty() {
        return;
    }
    all.sort_unstable();
    let ms = |ns: u64| ns as f64 * 1e-6;
    let mean = all.iter().sum::<u64>() as f64 / all.len() as f64;
    let size = std::mem::size_of::<PointCloud>() as f64;
    println!(
        "link/point_cloud_a_to_b: {} samples, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms; \
         {:.0} clouds/s, {:.0} MB/s of messages ({:.0} MB/s of the seed's points)",
        all.len(),
        ms(nearest_rank(&all, 0.5)),
        ms(nearest_rank(&all, 0.99)),
        ms(*all.last().unwrap()),
        1e9 / mean,
        size / mean * 1e3,
        (ROWS * COLS * 12) as f64 / mean * 1e3,
    );
}

criterion_group!(benches, cloud_across_link);
criterion_main!(benches);
