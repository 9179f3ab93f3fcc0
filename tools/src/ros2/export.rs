//! `export_ros2`: reads an aisle record, converts its raw payloads (see `convert`) and
//! writes the ROS 2 bag, through a temporary file beside the output that is renamed into
//! place only once the bag is complete (a failed export leaves no half-written bag, and
//! never touches the record).
//!
//! Knows the files and the MCAP channels of the bag; what each message becomes is
//! `convert`'s.

use super::convert::{RosConverter, RosMessage};
use super::{RosTopic, schemas};
use crate::aligned::AlignedBuf;
use crate::reader::{ReadError, RecordFile};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error(
        "{path} is not an aisle record: it has no raw aisle channel with a message \
         (make one with `aisle run --record`)"
    )]
    NotARecord { path: PathBuf },
    #[error("nothing of {path} could be read: {reason}")]
    Unreadable { path: PathBuf, reason: String },
    #[error("the output {path} is the record itself: choose another output file")]
    SameFile { path: PathBuf },
    #[error("cannot write {path}: {reason}")]
    Output { path: PathBuf, reason: String },
}

/// What an export wrote.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ExportSummary {
    /// Messages written, per ROS topic name.
    pub written: BTreeMap<&'static str, u64>,
    /// Raw messages read from the record.
    pub read: u64,
    /// Raw messages of a converted topic that yielded nothing (wrong size, counts out of
    /// range, non-finite values).
    pub skipped: u64,
    /// Where a damaged record stops being readable, naming the file (what came before is
    /// exported; `aisle export` then exits 2: the whole record could not be converted).
    pub damaged: Option<String>,
}

/// Writes the ROS 2 bag of the record `input` to `output` (replaced if it exists).
pub fn export_ros2(input: &Path, output: &Path) -> Result<ExportSummary, ExportError> {
    if crate::paths::same_file(input, output) {
        return Err(ExportError::SameFile {
            path: output.to_path_buf(),
        });
    }
    if output.is_dir() {
        return Err(ExportError::Output {
            path: output.to_path_buf(),
            reason: "it is a directory: name the bag file".into(),
        });
    }
    let record = RecordFile::open(input)?;
    let name = output
        .file_name()
        .map_or_else(|| "bag".into(), |n| n.to_string_lossy().into_owned());
    let partial = output.with_file_name(format!(".{name}.partial-{}", std::process::id()));
    let result = std::fs::File::create(&partial)
        .map_err(|e| e.to_string())
        .and_then(|f| write_bag(&record, std::io::BufWriter::new(f)))
        .map_err(|reason| ExportError::Output {
            path: output.to_path_buf(),
            reason,
        })
        .and_then(|summary| {
            if summary.read == 0 {
                let path = input.to_path_buf();
                return Err(match summary.damaged {
                    Some(reason) => ExportError::Unreadable { path, reason },
                    None => ExportError::NotARecord { path },
                });
            }
            std::fs::rename(&partial, output).map_err(|e| ExportError::Output {
                path: output.to_path_buf(),
                reason: e.to_string(),
            })?;
            Ok(summary)
        });
    if result.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    result
}

/// Writes the bag; an error is the reason the output could not be written.
fn write_bag(
    record: &RecordFile,
    w: impl std::io::Write + std::io::Seek,
) -> Result<ExportSummary, String> {
    let mut bag = Bag::new(w)?;
    let mut conv = RosConverter::default();
    let mut summary = ExportSummary::default();
    let mut buf = AlignedBuf::new();
    let mut out: Vec<RosMessage> = Vec::new();
    for m in record.raw_messages() {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                summary.damaged = Some(e.to_string());
                break;
            }
        };
        summary.read += 1;
        buf.set(&m.data);
        out.clear();
        conv.convert(&m.channel.topic, &buf, &mut out)
            .map_err(|e| format!("cannot encode a message: {e}"))?;
        for r in &out {
            bag.write(r, m.log_time)?;
        }
    }
    // A file cut at a record boundary reads to its end without an error, but it has no
    // summary: it was not finished, so it is as damaged as one cut mid-record.
    if summary.damaged.is_none() && !record.is_finalised() {
        summary.damaged = Some(format!(
            "{} has no summary: the recording was not finished (the file is truncated)",
            record.path().display()
        ));
    }
    summary.skipped = conv.skipped();
    summary.written = RosTopic::ALL
        .iter()
        .map(|t| (t.name(), bag.counts[t.index()]))
        .collect();
    bag.finish()?;
    Ok(summary)
}

/// The MCAP writer of the bag and its channels, one per [`RosTopic`].
struct Bag<W: std::io::Write + std::io::Seek> {
    mcap: mcap::Writer<W>,
    channels: Vec<u16>,
    counts: Vec<u64>,
}

impl<W: std::io::Write + std::io::Seek> Bag<W> {
    fn new(w: W) -> Result<Self, String> {
        let err = |e: mcap::McapError| e.to_string();
        let mut mcap = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("aisle-tools {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .create(w)
            .map_err(err)?;
        let mut schemas: BTreeMap<&str, u16> = BTreeMap::new();
        let mut channels = Vec::new();
        for topic in RosTopic::ALL {
            let ty = topic.type_name();
            let schema = match schemas.get(ty) {
                Some(&id) => id,
                None => {
                    let text =
                        schemas::definition(ty).ok_or_else(|| format!("no definition of {ty}"))?;
                    let id = mcap
                        .add_schema(ty, "ros2msg", text.as_bytes())
                        .map_err(err)?;
                    schemas.insert(ty, id);
                    id
                }
            };
            let meta = BTreeMap::from([(
                "offered_qos_profiles".to_string(),
                qos_yaml(topic.latched()),
            )]);
            channels.push(
                mcap.add_channel(schema, topic.name(), "cdr", &meta)
                    .map_err(err)?,
            );
        }
        let n = channels.len();
        Ok(Self {
            mcap,
            channels,
            counts: vec![0; n],
        })
    }

    fn write(&mut self, m: &RosMessage, log_time: u64) -> Result<(), String> {
        let i = m.topic.index();
        self.counts[i] += 1;
        let header = mcap::records::MessageHeader {
            channel_id: self.channels[i],
            sequence: self.counts[i] as u32,
            log_time,
            publish_time: m.stamp_ns,
        };
        self.mcap
            .write_to_known_channel(&header, &m.data)
            .map_err(|e| e.to_string())
    }

    fn finish(mut self) -> Result<(), String> {
        self.mcap.finish().map_err(|e| e.to_string())?;
        self.mcap.into_inner().flush().map_err(|e| e.to_string())
    }
}

/// The QoS a topic was offered with, as rosbag2 stores it in the channel metadata
/// (reliable, keep last; durability transient local for latched topics, else
/// volatile; no deadline, lifespan or lease: the "infinite" durations).
fn qos_yaml(latched: bool) -> String {
    let inf = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {durability}\n  \
         deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  \
         avoid_ros_namespace_conventions: false\n",
        depth = if latched { 1 } else { 10 },
        durability = if latched { 1 } else { 2 },
    )
}
