//! Comparing two lockstep records of the same run: what the protocol fixes must be
//! equal, what the wall clock decides may differ.

use std::path::Path;

/// Both records hold the same messages, topic by topic in the same order (publishers
/// of one topic ordered by tick and source: what arrives from two processes within a
/// tick may interleave either way), byte for byte except the fields measured on the
/// wall clock (`aisle_tools::diff::WALL_CLOCK_FIELDS`) and the heartbeats (sent on the
/// wall clock), up to `before_tick` (the run's last tick ends as the group is stopped:
/// what of it is recorded depends on when each process got its SIGTERM); returns how
/// many, and how many are `TickDone`s of the node `code`.
pub fn same_records(a: &Path, b: &Path, code: u32, before_tick: u64) -> (usize, usize) {
    let (ta, tb) = (by_topic(a, before_tick), by_topic(b, before_tick));
    assert_eq!(ta.keys().collect::<Vec<_>>(), tb.keys().collect::<Vec<_>>());
    let mut n = 0;
    for ((topic, ma), mb) in ta
        .iter()
        .zip(tb.values())
        .filter(|((t, _), _)| *t != "aisle/tick_done")
    {
        let per_source = |l: &[Keyed]| {
            let mut m = std::collections::BTreeMap::<(u32, u32), usize>::new();
            l.iter()
                .for_each(|(_, k, _)| *m.entry((k.2, k.3)).or_default() += 1);
            m
        };
        assert_eq!(
            ma.len(),
            mb.len(),
            "{topic}: message counts per (source, node) {:?} vs {:?}",
            per_source(ma),
            per_source(mb)
        );
        for (i, ((ty, ka, da), (_, kb, db))) in ma.iter().zip(mb).enumerate() {
            assert_eq!(ka, kb, "{topic} message {i}: log time, tick, source");
            let d = aisle_tools::diff::first_difference(
                ty,
                da,
                db,
                &aisle_tools::diff::WALL_CLOCK_FIELDS,
            );
            assert!(d.is_none(), "{topic} message {i}: {}", d.unwrap());
            n += 1;
        }
    }
    // Acknowledgements: who acknowledged which tick is the protocol (the same in both);
    // the order in which the recorder took them from two processes is not.
    let acked = |t: &std::collections::BTreeMap<String, Vec<Keyed>>| {
        let mut v: Vec<(u64, u32)> = t["aisle/tick_done"]
            .iter()
            .map(|(_, k, _)| (k.1, k.3))
            .collect();
        v.sort_unstable();
        v
    };
    let (aa, ab) = (acked(&ta), acked(&tb));
    assert!(aa == ab, "the acknowledgements differ");
    let mut ticks: Vec<u64> = aa
        .iter()
        .filter(|(_, node)| *node == code)
        .map(|(t, _)| *t)
        .collect();
    let acks = ticks.len();
    ticks.dedup();
    assert_eq!(
        ticks.len(),
        acks,
        "a tick acknowledged twice by the external node"
    );
    (n, acks)
}

type Keyed = (String, (u64, u64, u32, u32), Vec<u8>);

/// A record's messages per topic before `before_tick`, heartbeats and idle
/// acknowledgements left out, each sorted by (log time, tick,
/// source, and for `TickDone` the acknowledging node).
fn by_topic(path: &Path, before_tick: u64) -> std::collections::BTreeMap<String, Vec<Keyed>> {
    use aisle_messages::{Header, TickDone};
    let file = aisle_tools::reader::RecordFile::open(path).unwrap();
    let mut topics: std::collections::BTreeMap<String, Vec<Keyed>> = Default::default();
    let u64_at = |d: &[u8], at: usize| u64::from_le_bytes(d[at..at + 8].try_into().unwrap());
    let u32_at = |d: &[u8], at: usize| u32::from_le_bytes(d[at..at + 4].try_into().unwrap());
    for m in file.raw_messages() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        let idle = topic == "aisle/tick_done"
            && u32_at(&m.data, std::mem::offset_of!(TickDone, status))
                == aisle_messages::StageStatus::Idle as u32;
        // Heartbeats go by the wall clock; an idle acknowledgement (a tick nobody waits
        // for this node on, such as the controller's off ticks) may be skipped when a
        // newer tick is already there.
        if topic == "aisle/heartbeat" || idle {
            continue;
        }
        let node = if topic == "aisle/tick_done" {
            u32_at(&m.data, std::mem::offset_of!(TickDone, node))
        } else {
            0
        };
        let key = (
            m.log_time,
            u64_at(&m.data, std::mem::offset_of!(Header, tick)),
            u32_at(&m.data, std::mem::offset_of!(Header, source)),
            node,
        );
        if key.1 >= before_tick {
            continue;
        }
        let ty = m.channel.schema_name.clone().unwrap_or_default();
        topics.entry(topic).or_default().push((ty, key, m.data));
    }
    for list in topics.values_mut() {
        list.sort_by_key(|(_, k, _)| *k);
    }
    topics
}
