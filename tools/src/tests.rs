//! Round trips through the file format: write -> read byte-identical, and damaged files
//! (truncated, corrupted, not MCAP at all) give clear errors, never a panic.

use crate::reader::{ReadError, RecordFile};
use crate::synthetic::{synthetic_run, write_synthetic};
use crate::writer::{Compression, RecordWriter, WriteError, WriterOptions};
use std::io::Cursor;
use std::path::Path;

fn synthetic_bytes(ticks: u64, compression: Compression) -> Vec<u8> {
    synthetic_bytes_with(ticks, compression, true)
}

fn synthetic_bytes_with(ticks: u64, compression: Compression, trim: bool) -> Vec<u8> {
    let opts = WriterOptions {
        compression,
        chunk_size: 64 * 1024,
        trim_trailing_zeros: trim,
    };
    write_synthetic(Cursor::new(Vec::new()), ticks, opts)
        .unwrap()
        .into_inner()
}

#[test]
fn write_then_read_gives_identical_payloads_and_headers() {
    for (compression, trim) in [
        (Compression::None, false),
        (Compression::None, true),
        (Compression::Lz4, true),
        (Compression::Zstd, false),
    ] {
        let bytes = synthetic_bytes_with(40, compression, trim);
        let file = RecordFile::from_bytes(Path::new("mem.mcap"), bytes).unwrap();
        assert!(file.is_finalised());
        let expected = synthetic_run(40);
        let got: Vec<_> = file.raw_messages().collect::<Result<_, _>>().unwrap();
        assert_eq!(got.len(), expected.len(), "{compression:?}");
        for (g, e) in got.iter().zip(&expected) {
            assert_eq!(g.channel.topic, e.service);
            assert_eq!(g.log_time, e.log_time);
            assert_eq!(g.data, e.bytes.bytes(), "payload of {}", e.service);
            let stamp = u64::from_le_bytes(e.bytes.bytes()[8..16].try_into().unwrap());
            let seq = u64::from_le_bytes(e.bytes.bytes()[0..8].try_into().unwrap());
            assert_eq!(g.publish_time, stamp);
            assert_eq!(u64::from(g.sequence), seq);
            let info = crate::catalog::service_info(e.service).unwrap();
            assert_eq!(g.channel.meta("type_name"), Some(info.type_name));
            assert_eq!(g.channel.meta("size"), Some(info.size.to_string().as_str()));
            assert_eq!(
                g.channel.meta("schema_hash"),
                Some(aisle_messages::schema_hash_hex().as_str())
            );
            assert_eq!(g.channel.schema_name.as_deref(), Some(info.type_name));
        }
        let att = file.attachments().unwrap();
        assert_eq!(att.len(), 1);
        assert_eq!(att[0].name, "mission.toml");
    }
}

#[test]
fn viewer_channels_carry_foxglove_schemas() {
    let bytes = synthetic_bytes(40, Compression::Lz4);
    let file = RecordFile::from_bytes(Path::new("mem.mcap"), bytes).unwrap();
    let mut topics = std::collections::BTreeMap::new();
    for m in file.messages() {
        let m = m.unwrap();
        if !m.channel.is_raw() {
            let json = m.channel.topic.starts_with("/plot/");
            let encoding = if json { "json" } else { "protobuf" };
            assert_eq!(m.channel.message_encoding, encoding, "{}", m.channel.topic);
            *topics
                .entry((
                    m.channel.topic.clone(),
                    m.channel.schema_name.clone().unwrap(),
                ))
                .or_insert(0) += 1;
        }
    }
    for (topic, schema) in [
        ("/viz/scene", "foxglove.SceneUpdate"),
        ("/viz/lidar/points", "foxglove.PointCloud"),
        ("/viz/map/global", "foxglove.Grid"),
        ("/viz/map/local", "foxglove.Grid"),
        ("/viz/path/reference", "foxglove.PosesInFrame"),
        ("/viz/path/band", "foxglove.PosesInFrame"),
        ("/viz/path/driven", "foxglove.PosesInFrame"),
        ("/tf", "foxglove.FrameTransforms"),
        ("/viz/log", "foxglove.Log"),
        ("/plot/odometry", "aisle.plot.Odometry"),
        ("/plot/cmd_vel", "aisle.plot.Command"),
        ("/plot/teb", "aisle.plot.TebStep"),
        ("/plot/latency", "aisle.plot.StageLatency"),
    ] {
        let n = topics.get(&(topic.to_string(), schema.to_string()));
        assert!(n.is_some_and(|n| *n > 0), "{topic} {schema}: {topics:?}");
    }
}

#[test]
fn a_truncated_file_yields_its_readable_prefix_then_says_where_it_ends() {
    let bytes = synthetic_bytes(60, Compression::Lz4);
    let total = synthetic_run(60).len() as u64;
    // A cut inside the summary leaves every message readable, but not finalised.
    let file =
        RecordFile::from_bytes(Path::new("cut.mcap"), bytes[..bytes.len() - 100].to_vec()).unwrap();
    assert!(!file.is_finalised());
    assert_eq!(file.raw_messages().count() as u64, total);
    // Cuts inside the data section (before the summary).
    let data_end = mcap::read::footer(&bytes).unwrap().summary_start as usize;
    assert!(data_end > 0 && data_end < bytes.len());
    for cut in [data_end / 3, data_end / 2, data_end * 9 / 10, data_end - 30] {
        let file = RecordFile::from_bytes(Path::new("cut.mcap"), bytes[..cut].to_vec()).unwrap();
        assert!(!file.is_finalised());
        let mut ok = 0u64;
        let mut err = None;
        for m in file.raw_messages() {
            match m {
                Ok(_) => ok += 1,
                Err(e) => {
                    assert!(err.is_none(), "only one error");
                    err = Some(e);
                }
            }
        }
        let err = err.expect("a truncated file reports its end");
        let text = err.to_string();
        assert!(text.contains("cut.mcap"), "{text}");
        assert!(text.contains(&format!("after {ok} messages")), "{text}");
        // A cut after the last chunk (in the message indexes) loses no message, but the
        // file still says it was not finished.
        assert!(ok <= total, "cut at {cut}: {ok} of {total}");
        if cut <= data_end / 2 {
            assert!(ok < total, "cut at {cut}: {ok} of {total}");
        }
        if cut > data_end / 2 {
            assert!(ok > 0, "{text}");
        }
        match err {
            ReadError::Damaged {
                messages,
                last_log_time_ns,
                ..
            } => {
                assert_eq!(messages, ok);
                assert_eq!(last_log_time_ns.is_some(), ok > 0);
            }
            other => panic!("unexpected {other}"),
        }
    }
}

#[test]
fn corrupt_files_give_errors_never_panics() {
    let bytes = synthetic_bytes(6, Compression::Lz4);
    let payload_total = synthetic_run(6).len();
    // Flip bytes at many deterministic positions, and cut at many lengths.
    let mut errors = 0;
    let step = (bytes.len() / 61).max(1);
    for pos in (8..bytes.len()).step_by(step) {
        let mut bad = bytes.clone();
        bad[pos] ^= 0x5a;
        let Ok(file) = RecordFile::from_bytes(Path::new("bad.mcap"), bad) else {
            continue;
        };
        let results: Vec<_> = file.raw_messages().collect();
        let n_err = results.iter().filter(|r| r.is_err()).count();
        assert!(n_err <= 1);
        if n_err == 1 {
            errors += 1;
            assert!(results.last().unwrap().is_err(), "the error comes last");
        } else {
            // A flip the reader cannot see (in an index or padding) must leave the
            // payloads intact: chunk CRCs catch flips inside the data.
            assert!(results.len() <= payload_total);
        }
        let _ = file.attachments();
        let _ = file.metadata();
        let _ = file.is_finalised();
    }
    assert!(errors > 5, "corruption is detected ({errors})");
    for cut in (0..bytes.len()).step_by(step) {
        if let Ok(file) = RecordFile::from_bytes(Path::new("cut.mcap"), bytes[..cut].to_vec()) {
            let _ = file.raw_messages().count();
            let _ = file.attachments();
        }
    }
}

#[test]
fn not_an_mcap_file_is_refused_by_name() {
    let e = RecordFile::from_bytes(Path::new("notes.txt"), b"hello world".to_vec())
        .err()
        .unwrap();
    assert!(
        e.to_string().contains("notes.txt is not an MCAP file"),
        "{e}"
    );
    let e = RecordFile::open(Path::new("/nonexistent/run.mcap"))
        .err()
        .unwrap();
    assert!(e.to_string().contains("/nonexistent/run.mcap"), "{e}");
}

#[test]
fn the_writer_refuses_wrong_sizes_and_unknown_services() {
    let mut w = RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default()).unwrap();
    let e = w.write_raw("aisle/tick", 1, &[0u8; 10]).unwrap_err();
    assert!(matches!(e, WriteError::WrongSize { want: 72, .. }), "{e}");
    let e = w.write_raw("aisle/nope", 1, &[0u8; 72]).unwrap_err();
    assert!(e.to_string().contains("aisle/nope"), "{e}");
}

#[test]
fn trimming_trailing_zeros_is_lossless_and_smaller() {
    let trimmed = synthetic_bytes_with(10, Compression::None, true);
    let full = synthetic_bytes_with(10, Compression::None, false);
    assert!(
        trimmed.len() * 4 < full.len(),
        "{} vs {}",
        trimmed.len(),
        full.len()
    );
    let read = |b: Vec<u8>| -> Vec<Vec<u8>> {
        let f = RecordFile::from_bytes(Path::new("t.mcap"), b).unwrap();
        f.raw_messages().map(|m| m.unwrap().data).collect()
    };
    assert_eq!(read(trimmed), read(full));
    assert_eq!(crate::writer::trimmed_len(&[1, 0, 2, 0, 0]), 3);
    assert_eq!(crate::writer::trimmed_len(&[0; 17]), 0);
    let mut v = vec![0u8; 33];
    v[24] = 9;
    assert_eq!(crate::writer::trimmed_len(&v), 25);
}

#[test]
fn writing_is_deterministic() {
    assert_eq!(
        synthetic_bytes(20, Compression::Zstd),
        synthetic_bytes(20, Compression::Zstd)
    );
}

/// A record written before the envelope (`aisle-raw` channels, payloads as they are)
/// reads as it always did; an enveloped message that is not one is damage.
#[test]
fn older_records_without_the_envelope_still_read() {
    use aisle_messages::topics::names as s;
    let info = crate::catalog::service_info(s::TICK).unwrap();
    let mut payload = vec![0u8; info.size];
    payload[8] = 42;
    let meta = |raw: bool| {
        let mut m = std::collections::BTreeMap::from([
            ("type_name".to_string(), info.type_name.to_string()),
            ("size".to_string(), info.size.to_string()),
        ]);
        if raw {
            m.insert("aisle_raw".into(), "protobuf_envelope".into());
        }
        m
    };
    let write = |encoding: &str, raw: bool, data: &[u8]| {
        let mut w = mcap::Writer::new(Cursor::new(Vec::new())).unwrap();
        let schema = w.add_schema(info.type_name, "x", b"").unwrap();
        let ch = w
            .add_channel(schema, s::TICK, encoding, &meta(raw))
            .unwrap();
        let header = mcap::records::MessageHeader {
            channel_id: ch,
            sequence: 0,
            log_time: 5,
            publish_time: 5,
        };
        w.write_to_known_channel(&header, data).unwrap();
        w.finish().unwrap();
        w.into_inner().into_inner()
    };
    let legacy = write(crate::writer::LEGACY_RAW_ENCODING, false, &payload);
    let file = RecordFile::from_bytes(Path::new("old.mcap"), legacy).unwrap();
    let got: Vec<_> = file.raw_messages().map(Result::unwrap).collect();
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].data, payload);
    // Marked as enveloped, but the bytes are not an envelope: damaged, naming the topic.
    let bad = write("protobuf", true, &payload);
    let file = RecordFile::from_bytes(Path::new("bad.mcap"), bad).unwrap();
    let e = file.raw_messages().next().unwrap().unwrap_err();
    assert!(matches!(e, ReadError::Damaged { .. }), "{e}");
    assert!(e.to_string().contains(s::TICK), "{e}");
}
