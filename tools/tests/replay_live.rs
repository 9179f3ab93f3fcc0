//! Replay into a real (in-process) iceoryx2 instance: what a live subscriber receives
//! is byte-identical to what the file holds, for the selected services only.

use aisle_bus::{Bus, Instance};
use aisle_messages::topics::names as s;
use aisle_messages::{Tick, TickMode, topics};
use aisle_tools::synthetic::write_synthetic;
use aisle_tools::{RecordFile, ReplayOptions, WriterOptions, replay};
use std::fs::File;
use std::time::Duration;

/// Removes the instance's files even when an assertion fails.
struct Cleanup(Instance);

impl Drop for Cleanup {
    fn drop(&mut self) {
        let _ = self.0.remove();
    }
}

#[test]
fn replayed_payloads_arrive_byte_identical() {
    let path = std::env::temp_dir().join(format!("aisle-replay-{}.mcap", std::process::id()));
    // Small chunks, so that a file cut in half still has whole chunks to replay.
    let options = WriterOptions {
        chunk_size: 16 * 1024,
        ..WriterOptions::default()
    };
    write_synthetic(File::create(&path).unwrap(), 20, options).unwrap();
    let file = RecordFile::open(&path).unwrap();
    let expected: Vec<Vec<u8>> = file
        .raw_messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == s::TICK)
        .map(|m| m.data)
        .collect();
    assert_eq!(expected.len(), 20);

    let instance = Instance::unique(std::path::Path::new("/tmp/aisle-tt"));
    let _cleanup = Cleanup(instance.clone());
    let (bus, announce) = Bus::create_instance(&instance, 7, TickMode::Lockstep).unwrap();
    let ticks = bus.subscriber(topics::TICK).unwrap();
    let states = bus.subscriber(topics::ROBOT_STATE).unwrap();
    let mut opts = ReplayOptions::new(&path, instance.clone());
    opts.topics = vec![s::TICK.to_string()];
    // 20 ticks 10 ms apart, at 4x: about 50 ms, well within the tick buffer of 8 when
    // the test drains as it goes; drain on a thread.
    opts.rate = Some(4.0);
    opts.settle = Duration::from_millis(50);
    let handle = std::thread::spawn(move || replay(&opts));
    let mut got = Vec::new();
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while got.len() < 20 && std::time::Instant::now() < deadline {
        while let Some(t) = ticks.receive().unwrap() {
            got.push(aisle_tools::aligned::message_bytes::<Tick>(&t).to_vec());
        }
        // The replay joins late: it gets the announcement when the publisher updates
        // its connections, as the supervisor does in its loops.
        let _ = announce.update_connections();
        std::thread::sleep(Duration::from_millis(1));
    }
    let summary = handle.join().unwrap().unwrap();
    assert_eq!(summary.published.get(s::TICK), Some(&20));
    assert_eq!(summary.total(), 20);
    assert!(summary.truncated.is_none());
    assert_eq!(got, expected);
    assert!(
        states.receive().unwrap().is_none(),
        "unselected services stay silent"
    );

    // A truncated copy replays what can be read and says where it ends.
    let bytes = std::fs::read(&path).unwrap();
    let cut = path.with_extension("cut.mcap");
    let data_end = mcap::read::footer(&bytes).unwrap().summary_start as usize;
    std::fs::write(&cut, &bytes[..data_end / 2]).unwrap();
    let mut opts = ReplayOptions::new(&cut, instance.clone());
    opts.topics = vec![s::TICK.to_string()];
    opts.rate = None;
    opts.settle = Duration::from_millis(10);
    let handle = std::thread::spawn(move || replay(&opts));
    let mut received = 0;
    while !handle.is_finished() {
        while ticks.receive().unwrap().is_some() {
            received += 1;
        }
        let _ = announce.update_connections();
        std::thread::sleep(Duration::from_millis(1));
    }
    let summary = handle.join().unwrap().unwrap();
    let published = summary.published.get(s::TICK).copied().unwrap_or(0);
    assert!(published < 20, "{summary:?}");
    let note = summary
        .truncated
        .expect("the replay says where the file ends");
    assert!(note.contains("cut short"), "{note}");
    while ticks.receive().unwrap().is_some() {
        received += 1;
    }
    assert!(received <= published);

    drop((ticks, states, announce, bus));
    instance.remove().unwrap();
    std::fs::remove_file(&path).unwrap();
    std::fs::remove_file(&cut).unwrap();
}
