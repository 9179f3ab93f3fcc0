//! The recorder on a real (in-process) iceoryx2 instance: it joins, reports Ready,
//! records what is published byte for byte, and finalises the file on a stop request.
//! Its own test binary because the stop request is process-wide.

use aisle_bus::{Bus, Instance, NodeArgs, Stamp, WaitOutcome, signals};
use aisle_messages::topics::names as s;
use aisle_messages::{
    NodeKind, NodeState, RobotState, StageStatus, Tick, TickDone, TickMode, topics,
};
use aisle_tools::aligned::{message_bytes, zeroed_box};
use aisle_tools::{RecordFile, RecorderOptions, run_recorder_with};
use std::path::PathBuf;
use std::time::Duration;

/// Removes the instance's files even when an assertion fails.
struct Cleanup(Instance);

impl Drop for Cleanup {
    fn drop(&mut self) {
        let _ = self.0.remove();
    }
}

#[test]
fn records_published_payloads_byte_for_byte_and_finalises_on_stop() {
    let instance = Instance::unique(std::path::Path::new("/tmp/aisle-tt"));
    let _cleanup = Cleanup(instance.clone());
    let (bus, announce) = Bus::create_instance(&instance, 7, TickMode::Lockstep).unwrap();
    let hb = bus.subscriber(topics::HEARTBEAT).unwrap();
    let mut ticks = bus.publisher(topics::TICK).unwrap();
    let mut robot = bus.publisher(topics::ROBOT_STATE).unwrap();

    let config_dir = std::env::temp_dir().join(format!("aisle-rec-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&config_dir).unwrap();
    std::fs::write(config_dir.join("mission.toml"), "[mission]\n").unwrap();
    let out: PathBuf = std::env::temp_dir().join(format!("aisle-rec-{}.mcap", std::process::id()));
    let args = NodeArgs {
        instance: instance.clone(),
        config_dir: config_dir.clone(),
        dt_ns: 100_000_000,
        controller_every: 5,
        start: [0.0, 0.0, 0.0],
        lidar_off: false,
        restarted: false,
        recorded: false,
    };
    let recorder = {
        let out = out.clone();
        std::thread::spawn(move || run_recorder_with(&args, &out, &RecorderOptions::default()))
    };
    let (outcome, _) = hb
        .wait_for(
            Duration::from_secs(20),
            |h| h.node == NodeKind::Recorder.code() && h.state == NodeState::Ready as u32,
            // A late subscriber gets the announcement (history) only when the publisher
            // updates its connections, as the supervisor does in its loops.
            || {
                let _ = announce.update_connections();
            },
        )
        .unwrap();
    if outcome != WaitOutcome::Matched {
        let result = recorder.join().unwrap();
        panic!("the recorder did not report Ready: {result:?}");
    }

    // Paced like a lockstep group: tick k, its robot state, the supervisor's
    // acknowledgement, then the recorder's. Paced by sleeps instead, a host that held
    // the recorder past four publications dropped tick 1 from its buffer unseen (a
    // publisher's first sample cannot be known lost).
    let mut acks = bus.publisher(topics::TICK_DONE).unwrap();
    let dones = bus.subscriber(topics::TICK_DONE).unwrap();
    let mut sent_ticks = Vec::new();
    let mut sent_states = Vec::new();
    for k in 1..=50u64 {
        let mut t = zeroed_box::<Tick>();
        t.header.seq = k;
        t.header.stamp_ns = k * 100_000_000;
        t.header.tick = k;
        t.seed = 0xdead_beef ^ k;
        ticks.publish_bytes(message_bytes(&*t)).unwrap();
        sent_ticks.push(message_bytes(&*t).to_vec());
        let mut r = zeroed_box::<RobotState>();
        r.header.seq = k;
        r.header.stamp_ns = k * 100_000_000;
        r.pose.x = k as f64 * 0.01;
        robot.publish_bytes(message_bytes(&*r)).unwrap();
        sent_states.push(message_bytes(&*r).to_vec());
        let stamp = Stamp {
            tick: k,
            ..Stamp::default()
        };
        acks.publish(stamp, |m| {
            m.node = NodeKind::Supervisor.code();
            m.status = StageStatus::Done as u32;
        })
        .unwrap();
        let recorder_done =
            |d: &TickDone| d.node == NodeKind::Recorder.code() && d.header.tick == k;
        let (outcome, _) = dones
            .wait_for(Duration::from_secs(20), recorder_done, || {})
            .unwrap();
        assert_eq!(
            outcome,
            WaitOutcome::Matched,
            "the recorder did not acknowledge tick {k}"
        );
    }
    signals::request_stop();
    let summary = recorder.join().unwrap().unwrap();
    assert_eq!(summary.lost(), 0, "{summary:?}");
    assert_eq!(summary.written.get(s::TICK), Some(&50));

    let file = RecordFile::open(&out).unwrap();
    assert!(file.is_finalised());
    let mut got_ticks = Vec::new();
    let mut got_states = Vec::new();
    for m in file.raw_messages() {
        let m = m.unwrap();
        match m.channel.topic.as_str() {
            s::TICK => got_ticks.push(m.data),
            s::ROBOT_STATE => got_states.push(m.data),
            _ => {}
        }
    }
    assert_eq!(got_ticks, sent_ticks);
    assert_eq!(got_states, sent_states);
    let att = file.attachments().unwrap();
    assert_eq!(att.len(), 1);
    assert_eq!(att[0].name, "mission.toml");
    let meta = file.metadata().unwrap();
    assert!(
        meta.iter()
            .any(|(n, m)| n == "aisle.recorder" && m["lost_total"] == "0")
    );

    drop((hb, ticks, robot, acks, dones, announce, bus));
    instance.remove().unwrap();
    std::fs::remove_file(&out).unwrap();
    std::fs::remove_dir_all(&config_dir).unwrap();
}
