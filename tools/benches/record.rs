//! Recorder throughput: one seed-sized tick (a 31 x 1201 point cloud, a 150 x 150 local
//! map, robot state, ground truth, tick and three acknowledgements; a trajectory and
//! band every 5th tick) written as raw and viewer channels. The recorder must keep up
//! with a lockstep run of about 300 ticks/s, i.e. at most ~3.3 ms per tick.

use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, Message, OccupancyGrid, PointCloud, RobotState, Tick, TickDone, Trajectory,
    WorldTruth,
};
use aisle_tools::aligned::{AlignedBuf, message_bytes, zeroed_box};
use aisle_tools::viewer::{ViewerConverter, ViewerOptions};
use aisle_tools::{Compression, RecordWriter, WriterOptions};
use criterion::{Criterion, criterion_group, criterion_main};
use std::io::{Seek, SeekFrom, Write};

/// A file that keeps nothing: measures the recorder, not the page cache.
#[derive(Default)]
struct Discard {
    pos: u64,
    len: u64,
}

impl Write for Discard {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.pos += b.len() as u64;
        self.len = self.len.max(self.pos);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for Discard {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.pos = match to {
            SeekFrom::Start(p) => p,
            SeekFrom::End(d) => self.len.saturating_add_signed(d),
            SeekFrom::Current(d) => self.pos.saturating_add_signed(d),
        };
        Ok(self.pos)
    }
}

fn buf<M: Message>(m: &M) -> AlignedBuf {
    AlignedBuf::from_bytes(message_bytes(m))
}

fn tick_samples() -> Vec<(&'static str, AlignedBuf)> {
    let mut cloud = zeroed_box::<PointCloud>();
    cloud.rows = 31;
    cloud.cols = 1201;
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    for p in cloud.points[..31 * 1201].iter_mut() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let r = (state % 12_000) as f32 / 1000.0;
        *p = if state.is_multiple_of(5) {
            [f32::NAN; 3]
        } else {
            [r * 0.8, r * 0.5, r * 0.1]
        };
    }
    let mut local = zeroed_box::<OccupancyGrid>();
    local.width = 150;
    local.height = 150;
    local.resolution = 0.1;
    for (i, c) in local.cells[..150 * 150].iter_mut().enumerate() {
        *c = u8::from(i % 37 == 0);
    }
    let mut truth = zeroed_box::<WorldTruth>();
    truth.len = 30;
    for (i, b) in truth.bodies[..30].iter_mut().enumerate() {
        b.pose.x = i as f64;
        b.size = [1.0, 1.0, 2.0];
        b.is_static = u8::from(i > 2);
    }
    let mut done = zeroed_box::<TickDone>();
    done.compute_ns = 1;
    vec![
        (s::ROBOT_STATE, buf(&*zeroed_box::<RobotState>())),
        (s::WORLD_TRUTH, buf(&*truth)),
        (s::TICK, buf(&*zeroed_box::<Tick>())),
        (s::POINT_CLOUD, buf(&*cloud)),
        (s::TICK_DONE, buf(&*done)),
        (s::LOCAL_MAP, buf(&*local)),
        (s::TICK_DONE, buf(&*done)),
        (s::TRAJECTORY, buf(&*zeroed_box::<Trajectory>())),
        (s::CONTROLLER_BAND, buf(&*zeroed_box::<ControllerBand>())),
        (s::TICK_DONE, buf(&*done)),
    ]
}

fn bench(c: &mut Criterion) {
    let samples = tick_samples();
    let mut group = c.benchmark_group("record_tick");
    group.sample_size(20);
    for (compression, trim) in [
        (Compression::Lz4, true),
        (Compression::Lz4, false),
        (Compression::Zstd, true),
        (Compression::None, true),
    ] {
        let name = format!("{compression:?}{}", if trim { "" } else { "_untrimmed" });
        group.bench_function(name, |b| {
            let mut w = RecordWriter::new(
                Discard::default(),
                WriterOptions {
                    compression,
                    trim_trailing_zeros: trim,
                    ..WriterOptions::default()
                },
            )
            .unwrap();
            let mut conv = ViewerConverter::new(ViewerOptions::default());
            let mut out = Vec::new();
            let mut t = 0u64;
            let mut k = 0u64;
            b.iter(|| {
                k += 1;
                for (svc, m) in &samples {
                    // Trajectory and band come every 5th tick.
                    if (*svc == s::TRAJECTORY || *svc == s::CONTROLLER_BAND) && !k.is_multiple_of(5)
                    {
                        continue;
                    }
                    t += 1000;
                    w.write_raw(svc, t, m.bytes()).unwrap();
                    conv.recycle(&mut out);
                    conv.convert(svc, m, &mut out);
                    for v in &out {
                        w.write_viewer(v, t).unwrap();
                    }
                }
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
