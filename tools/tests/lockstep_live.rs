//! Lockstep replay into a real (in-process) iceoryx2 instance with a stand-in mapper
//! that answers every point cloud with the maps recorded for that tick: each tick's
//! inputs arrive once, in order, never before the previous tick was acknowledged; the
//! comparison finds nothing when the answers are the recorded ones and names tick and
//! field when one cell differs; a consumer that dies ends the replay with its name.

use aisle_bus::{Bus, Instance, Publisher, Stamp, WaitOutcome};
use aisle_messages::topics::names as s;
use aisle_messages::{GlobalGrid, NodeKind, OccupancyGrid, StageStatus, TickMode, topics};
use aisle_tools::lockstep::{LockstepOptions, LockstepPorts, replay_lockstep};
use aisle_tools::replay::ReplayError;
use aisle_tools::synthetic::write_synthetic;
use aisle_tools::tick_batches::{BatchOptions, TickBatches, header_fields};
use aisle_tools::{RecordFile, RecordWriter, WriterOptions};
use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

const TICKS: u64 = 20;

struct Cleanup(Instance, Vec<PathBuf>);

impl Drop for Cleanup {
    fn drop(&mut self) {
        let _ = self.0.remove();
        for p in &self.1 {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Recorded mapper outputs by tick: (service, payload) in file order.
fn recorded_maps(file: &RecordFile) -> BTreeMap<u64, Vec<(String, Vec<u8>)>> {
    let mut out: BTreeMap<u64, Vec<(String, Vec<u8>)>> = BTreeMap::new();
    for m in file.raw_messages().map(Result::unwrap) {
        let t = m.channel.topic.as_str();
        if t == s::LOCAL_MAP || t == s::GLOBAL_MAP {
            let tick = header_fields(&m.data).tick;
            out.entry(tick).or_default().push((t.to_string(), m.data));
        }
    }
    out
}

/// What the stand-in saw: ticks of the clouds in arrival order, and whether a cloud
/// was already waiting when it acknowledged the one before.
struct Seen {
    clouds: Vec<u64>,
    early: bool,
}

/// A stand-in mapper: for each cloud publishes the recorded maps of its tick (one cell
/// changed at `corrupt_at`) and acknowledges it; stops after `stop_after` clouds.
fn stand_in(
    instance: Instance,
    maps: BTreeMap<u64, Vec<(String, Vec<u8>)>>,
    corrupt_at: Option<u64>,
    stop_after: u64,
    ready: mpsc::Sender<()>,
) -> JoinHandle<Seen> {
    std::thread::spawn(move || {
        let (bus, _) = Bus::join(&instance, NodeKind::Mapper, Duration::from_secs(10)).unwrap();
        let clouds = bus.subscriber(topics::POINT_CLOUD).unwrap();
        let mut local: Publisher<OccupancyGrid> = bus.publisher(topics::LOCAL_MAP).unwrap();
        let mut global: Publisher<GlobalGrid> = bus.publisher(topics::GLOBAL_MAP).unwrap();
        let mut acks = bus.publisher(topics::TICK_DONE).unwrap();
        ready.send(()).unwrap();
        let mut seen = Seen {
            clouds: Vec::new(),
            early: false,
        };
        while (seen.clouds.len() as u64) < stop_after {
            let (outcome, cloud) = clouds
                .wait_for(Duration::from_secs(10), |_| true, || {})
                .unwrap();
            let (WaitOutcome::Matched, Some(cloud)) = (outcome, cloud) else {
                break;
            };
            let header = cloud.header;
            drop(cloud);
            seen.clouds.push(header.tick);
            for (service, bytes) in maps.get(&header.tick).into_iter().flatten() {
                let mut bytes = bytes.clone();
                if corrupt_at == Some(header.tick) && service == s::LOCAL_MAP {
                    let at = std::mem::offset_of!(OccupancyGrid, cells) + 5;
                    bytes[at] ^= 2;
                }
                if service == s::LOCAL_MAP {
                    local.publish_bytes(&bytes)
                } else {
                    global.publish_bytes(&bytes)
                }
                .unwrap();
            }
            // Slow on purpose: the replay must wait for the acknowledgement.
            std::thread::sleep(Duration::from_millis(2));
            seen.early |= clouds.receive().unwrap().is_some();
            acks.publish(Stamp::of(&header), |m| {
                m.node = NodeKind::Mapper.code();
                m.status = StageStatus::Done as u32;
            })
            .unwrap();
        }
        seen
    })
}

fn options(path: &Path) -> LockstepOptions {
    LockstepOptions {
        file: path.to_path_buf(),
        publish: [s::TICK, s::ROBOT_STATE, s::POINT_CLOUD, s::CONTROLLER_GOAL]
            .map(String::from)
            .to_vec(),
        consumers: vec![NodeKind::Mapper],
        compare: vec![
            (s::GLOBAL_MAP.to_string(), NodeKind::Mapper),
            (s::LOCAL_MAP.to_string(), NodeKind::Mapper),
        ],
        start_offset_ns: 0,
        ack_timeout: Duration::from_secs(20),
    }
}

#[test]
fn lockstep_replay_paces_by_acknowledgements_and_compares_outputs() {
    let path = std::env::temp_dir().join(format!("aisle-lockstep-{}.mcap", std::process::id()));
    let options_small = WriterOptions {
        chunk_size: 16 * 1024,
        ..WriterOptions::default()
    };
    write_synthetic(File::create(&path).unwrap(), TICKS, options_small).unwrap();
    let file = RecordFile::open(&path).unwrap();
    let maps = recorded_maps(&file);
    let instance = Instance::unique(Path::new("/tmp/aisle-tt"));
    let _cleanup = Cleanup(instance.clone(), vec![path.clone()]);
    let (bus, announce) = Bus::create_instance(&instance, 7, TickMode::Lockstep).unwrap();
    let opts = options(&path);

    for corrupt_at in [None, Some(7)] {
        let mut ports = LockstepPorts::open(&bus, &file, &opts).unwrap();
        let (tx, rx) = mpsc::channel();
        let mapper = stand_in(instance.clone(), maps.clone(), corrupt_at, TICKS, tx);
        while rx.try_recv().is_err() {
            announce.update_connections().unwrap();
            std::thread::sleep(Duration::from_millis(1));
        }
        let summary = replay_lockstep(&mut ports, &file, &opts, &mut || Ok(())).unwrap();
        let seen = mapper.join().unwrap();
        assert_eq!(seen.clouds, (0..TICKS).collect::<Vec<_>>());
        assert!(
            !seen.early,
            "a cloud was published before the last was acknowledged"
        );
        assert_eq!(summary.ticks, TICKS);
        assert_eq!(summary.published.get(s::POINT_CLOUD), Some(&TICKS));
        assert_eq!(summary.published.get(s::TICK), Some(&TICKS));
        assert_eq!(summary.compared.get(s::LOCAL_MAP), Some(&TICKS));
        assert!(summary.compared.get(s::GLOBAL_MAP).is_some_and(|n| *n > 0));
        match corrupt_at {
            None => {
                assert!(summary.identical(), "{summary:?}");
            }
            Some(k) => {
                assert!(!summary.identical());
                let d = summary.first.clone().unwrap();
                assert_eq!((d.service.as_str(), d.tick), (s::LOCAL_MAP, k), "{d}");
                assert!(d.detail.starts_with("cells[5]:"), "{d}");
                assert_eq!(summary.diverged.get(s::LOCAL_MAP), Some(&1));
            }
        }
    }

    // A consumer that stops answering: the replay ends naming what the probe said.
    let mut ports = LockstepPorts::open(&bus, &file, &opts).unwrap();
    let (tx, rx) = mpsc::channel();
    let mapper = stand_in(instance.clone(), maps.clone(), None, 4, tx);
    while rx.try_recv().is_err() {
        announce.update_connections().unwrap();
        std::thread::sleep(Duration::from_millis(1));
    }
    let err = replay_lockstep(&mut ports, &file, &opts, &mut || {
        if mapper.is_finished() {
            Err("the stand-in mapper is gone".into())
        } else {
            Ok(())
        }
    })
    .unwrap_err();
    assert!(matches!(err, ReplayError::ConsumerGone(_)), "{err}");
    assert!(err.to_string().contains("stand-in mapper"), "{err}");
    drop((ports, announce, bus));
}

/// The synthetic run with the mapper's part of its last tick cut off, as when the
/// group stops while the mapper still works on the tick after the mission's last.
fn write_cut_short(path: &Path) {
    let mut w = RecordWriter::new(File::create(path).unwrap(), WriterOptions::default()).unwrap();
    for sample in aisle_tools::synthetic::synthetic_run(TICKS) {
        let bytes = sample.bytes.bytes();
        let last = header_fields(bytes).tick == TICKS - 1;
        let mapper_ack = sample
            .bytes
            .view::<aisle_messages::TickDone>()
            .is_some_and(|d| sample.service == s::TICK_DONE && d.node == NodeKind::Mapper.code());
        let map = sample.service == s::LOCAL_MAP || sample.service == s::GLOBAL_MAP;
        if last && (mapper_ack || map) {
            continue;
        }
        w.write_raw(sample.service, sample.log_time, bytes).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_consumer_cut_off_in_the_last_tick_is_not_compared_there() {
    let path = std::env::temp_dir().join(format!("aisle-cut-{}.mcap", std::process::id()));
    write_cut_short(&path);
    let file = RecordFile::open(&path).unwrap();
    // The stand-in answers the last tick with the maps of the full synthetic run.
    let full = std::env::temp_dir().join(format!("aisle-full-{}.mcap", std::process::id()));
    write_synthetic(
        File::create(&full).unwrap(),
        TICKS,
        WriterOptions::default(),
    )
    .unwrap();
    let maps = recorded_maps(&RecordFile::open(&full).unwrap());
    let instance = Instance::unique(Path::new("/tmp/aisle-tt"));
    let _cleanup = Cleanup(instance.clone(), vec![path.clone(), full]);
    let (bus, announce) = Bus::create_instance(&instance, 7, TickMode::Lockstep).unwrap();
    let opts = options(&path);
    let mut ports = LockstepPorts::open(&bus, &file, &opts).unwrap();
    let (tx, rx) = mpsc::channel();
    let mapper = stand_in(instance.clone(), maps, None, TICKS, tx);
    while rx.try_recv().is_err() {
        announce.update_connections().unwrap();
        std::thread::sleep(Duration::from_millis(1));
    }
    let summary = replay_lockstep(&mut ports, &file, &opts, &mut || Ok(())).unwrap();
    // The live mapper's last maps may or may not have arrived when the replay looked:
    // either way that tick is not compared, and the ticks before it are.
    mapper.join().unwrap();
    assert!(summary.identical(), "{summary:?}");
    assert_eq!(summary.cut_short, vec![NodeKind::Mapper]);
    assert_eq!(summary.compared.get(s::LOCAL_MAP), Some(&(TICKS - 1)));
    drop((ports, announce, bus));
}

#[test]
fn a_realtime_recording_is_refused_for_lockstep() {
    let path = std::env::temp_dir().join(format!("aisle-realtime-{}.mcap", std::process::id()));
    let mut w = RecordWriter::new(File::create(&path).unwrap(), WriterOptions::default()).unwrap();
    w.write_metadata("aisle", BTreeMap::from([("mode".into(), "1".into())]))
        .unwrap();
    let tick = aisle_tools::aligned::zeroed_box::<aisle_messages::Tick>();
    w.write_raw(s::TICK, 1, aisle_tools::aligned::message_bytes(&*tick))
        .unwrap();
    w.finish().unwrap();
    let file = RecordFile::open(&path).unwrap();
    let instance = Instance::unique(Path::new("/tmp/aisle-tt"));
    let _cleanup = Cleanup(instance.clone(), vec![path.clone()]);
    let (bus, _announce) = Bus::create_instance(&instance, 7, TickMode::Lockstep).unwrap();
    let mut opts = options(&path);
    opts.compare.clear();
    opts.publish = vec![s::TICK.to_string()];
    let err = LockstepPorts::open(&bus, &file, &opts).err().unwrap();
    assert!(matches!(err, ReplayError::NotLockstep { .. }), "{err}");
    assert!(err.to_string().contains("aisle-realtime-"), "{err}");
}

/// A stand-in controller that answers only the ticks flagged for it, each after a
/// pause; returns the ticks it saw and whether a tick arrived before it answered the
/// controller tick before it.
fn stand_in_controller(instance: Instance, ready: mpsc::Sender<()>) -> JoinHandle<Seen> {
    std::thread::spawn(move || {
        let (bus, _) =
            Bus::join(&instance, NodeKind::TebController, Duration::from_secs(10)).unwrap();
        let ticks = bus.subscriber(topics::TICK).unwrap();
        let mut acks = bus.publisher(topics::TICK_DONE).unwrap();
        ready.send(()).unwrap();
        let mut seen = Seen {
            clouds: Vec::new(),
            early: false,
        };
        loop {
            let (outcome, tick) = ticks
                .wait_for(Duration::from_secs(2), |_| true, || {})
                .unwrap();
            let (WaitOutcome::Matched, Some(tick)) = (outcome, tick) else {
                break;
            };
            let (header, stages) = (tick.header, tick.stages);
            drop(tick);
            seen.clouds.push(header.tick);
            if stages & aisle_messages::STAGE_CONTROLLER == 0 {
                continue;
            }
            std::thread::sleep(Duration::from_millis(5));
            seen.early |= ticks.receive().unwrap().is_some();
            acks.publish(Stamp::of(&header), |m| {
                m.node = NodeKind::TebController.code();
                m.status = StageStatus::Done as u32;
            })
            .unwrap();
        }
        seen
    })
}

/// The synthetic record holds the controller's idle acknowledgement of every tick not
/// flagged for it, as a live controller gives when it sees such a tick; the live
/// simulator never waited for them, and a controller that takes only the newest tick
/// may skip some. The replay waits for the controller on its own ticks only.
#[test]
fn a_replay_does_not_wait_for_acknowledgements_the_simulator_did_not_wait_for() {
    let path = std::env::temp_dir().join(format!("aisle-idle-{}.mcap", std::process::id()));
    write_synthetic(
        File::create(&path).unwrap(),
        TICKS,
        WriterOptions::default(),
    )
    .unwrap();
    let file = RecordFile::open(&path).unwrap();
    let idle_acks = TickBatches::new(&file, BatchOptions::default())
        .filter(|b| b.stages == Some(0))
        .filter(|b| b.acked.iter().any(|(n, _)| *n == NodeKind::TebController))
        .count();
    assert_eq!(idle_acks as u64, TICKS - TICKS / 5, "the record holds them");
    let instance = Instance::unique(Path::new("/tmp/aisle-tt"));
    let _cleanup = Cleanup(instance.clone(), vec![path.clone()]);
    let (bus, announce) = Bus::create_instance(&instance, 7, TickMode::Lockstep).unwrap();
    let opts = LockstepOptions {
        publish: vec![s::TICK.to_string()],
        consumers: vec![NodeKind::TebController],
        compare: Vec::new(),
        ack_timeout: Duration::from_secs(5),
        ..options(&path)
    };
    let mut ports = LockstepPorts::open(&bus, &file, &opts).unwrap();
    let (tx, rx) = mpsc::channel();
    let controller = stand_in_controller(instance.clone(), tx);
    while rx.try_recv().is_err() {
        announce.update_connections().unwrap();
        std::thread::sleep(Duration::from_millis(1));
    }
    let summary = replay_lockstep(&mut ports, &file, &opts, &mut || Ok(())).unwrap();
    let seen = controller.join().unwrap();
    assert_eq!(summary.ticks, TICKS);
    assert!(
        !seen.early,
        "a tick was published before the controller answered its own"
    );
    assert_eq!(*seen.clouds.last().unwrap(), TICKS - 1);
    drop((ports, announce, bus));
}
