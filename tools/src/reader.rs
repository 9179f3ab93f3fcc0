//! Reads an aisle MCAP file: its messages in file order (raw payloads, out of their
//! envelope, or viewer messages), its attachments and metadata, and where a damaged file
//! stops being readable. Records written before the envelope (`aisle-raw` channels) read
//! the same.
//!
//! The file is read into memory once. A truncated or corrupt file yields every message
//! before the damage and then one [`ReadError::Damaged`] that says after which message
//! and at which log time the readable part ends; nothing here panics on bad bytes.
//! This module knows the file format, not the bus or what the payloads mean.

use crate::writer::{LEGACY_RAW_ENCODING, RAW_ENVELOPE, RAW_KEY, TRIMMED_KEY};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path} is not an MCAP file (it does not start with the MCAP magic bytes)")]
    NotMcap { path: PathBuf },
    #[error(
        "{path} is damaged: the readable part ends after {messages} messages{}; {reason}",
        match last_log_time_ns { Some(t) => format!(" (last log time {t} ns)"), None => String::new() }
    )]
    Damaged {
        path: PathBuf,
        messages: u64,
        last_log_time_ns: Option<u64>,
        reason: String,
    },
}

/// A channel of the file as the reader saw it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    pub id: u16,
    pub topic: String,
    pub message_encoding: String,
    pub schema_name: Option<String>,
    pub metadata: BTreeMap<String, String>,
}

impl ChannelInfo {
    /// True for the raw payload channels (one per service): marked by their metadata,
    /// or, in older records, by their own encoding.
    pub fn is_raw(&self) -> bool {
        self.enveloped() || self.message_encoding == LEGACY_RAW_ENCODING
    }

    /// True when the raw payloads are stored in a protobuf envelope (`crate::envelope`).
    pub fn enveloped(&self) -> bool {
        self.meta(RAW_KEY) == Some(RAW_ENVELOPE)
    }

    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata.get(key).map(String::as_str)
    }

    /// The size raw payloads are padded back to, when they were stored trimmed.
    pub fn padded_size(&self) -> Option<usize> {
        if !self.is_raw() || self.meta(TRIMMED_KEY) != Some("true") {
            return None;
        }
        // Capacity bound: a corrupt size must not make the reader allocate without limit.
        self.meta("size")?
            .parse()
            .ok()
            .filter(|&n: &usize| n <= 64 << 20)
    }
}

/// One message of the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileMessage {
    pub channel: Arc<ChannelInfo>,
    pub sequence: u32,
    pub log_time: u64,
    pub publish_time: u64,
    pub data: Vec<u8>,
}

/// An attachment of the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileAttachment {
    pub name: String,
    pub media_type: String,
    pub log_time: u64,
    pub data: Vec<u8>,
}

/// A metadata record: its name and entries.
pub type MetadataRecord = (String, BTreeMap<String, String>);

/// An MCAP file held in memory.
pub struct RecordFile {
    path: PathBuf,
    buf: Vec<u8>,
}

impl RecordFile {
    pub fn open(path: &Path) -> Result<Self, ReadError> {
        let io = |source| ReadError::Io {
            path: path.to_path_buf(),
            source,
        };
        // A FIFO or a device would be read until its writer stops: a record is a file.
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "not a regular file (a directory, a FIFO or a device)",
            )));
        }
        let buf = std::fs::read(path).map_err(io)?;
        Self::from_bytes(path, buf)
    }

    /// A file already in memory; `path` only names it in errors.
    pub fn from_bytes(path: &Path, buf: Vec<u8>) -> Result<Self, ReadError> {
        if !buf.starts_with(mcap::MAGIC) {
            return Err(ReadError::NotMcap {
                path: path.to_path_buf(),
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            buf,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn len_bytes(&self) -> usize {
        self.buf.len()
    }

    /// True when the file has its summary and footer (it was finalised).
    pub fn is_finalised(&self) -> bool {
        matches!(mcap::Summary::read(&self.buf), Ok(Some(_)))
    }

    /// Every message in file order; after a damaged part, one `Err` and then nothing.
    pub fn messages(&self) -> Messages<'_> {
        // Each chunk is decompressed whole and its CRC checked before any record in it is
        // parsed, so a corrupt chunk is refused before a garbage length inside it could
        // be used; record and chunk sizes are bounded so no corrupt size allocates
        // without limit.
        let options = mcap::sans_io::LinearReaderOptions::default()
            .with_skip_end_magic(true)
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(MAX_RECORD_BYTES);
        Messages {
            file: self,
            reader: Some(mcap::sans_io::LinearReader::new_with_options(options)),
            fed: 0,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            count: 0,
            last_log_time: None,
            raw_only: false,
        }
    }

    /// The raw payload messages only (one per received sample).
    pub fn raw_messages(&self) -> Messages<'_> {
        Messages {
            raw_only: true,
            ..self.messages()
        }
    }

    /// Every attachment readable before any damage.
    pub fn attachments(&self) -> Result<Vec<FileAttachment>, ReadError> {
        let mut out = Vec::new();
        self.scan_records(|r| {
            if let mcap::records::Record::Attachment { header, data, .. } = r {
                out.push(FileAttachment {
                    name: header.name,
                    media_type: header.media_type,
                    log_time: header.log_time,
                    data: data.into_owned(),
                });
            }
        })?;
        Ok(out)
    }

    /// Calls `f` with the topic and payload of every raw message, in file order, in one
    /// reused aligned buffer (so `view` gives the message). Returns where a damaged file
    /// stops being readable.
    pub fn for_each_payload(
        &self,
        mut f: impl FnMut(&str, &crate::aligned::AlignedBuf),
    ) -> Option<String> {
        let mut buf = crate::aligned::AlignedBuf::new();
        for m in self.raw_messages() {
            match m {
                Ok(m) => {
                    buf.set(&m.data);
                    f(&m.channel.topic, &buf);
                }
                Err(e) => return Some(e.to_string()),
            }
        }
        None
    }

    /// Raw channels that have at least one readable sample, by topic (one pass over the
    /// messages).
    pub fn recorded_raw_channels(&self) -> BTreeMap<String, ChannelInfo> {
        let mut out = BTreeMap::new();
        for m in self.raw_messages() {
            let Ok(m) = m else { break };
            out.entry(m.channel.topic.clone())
                .or_insert_with(|| (*m.channel).clone());
        }
        out
    }

    /// The run's metadata the recorder wrote (`aisle`: seed, clock mode, tick length,
    /// start pose...); empty when the file has none.
    pub fn run_metadata(&self) -> BTreeMap<String, String> {
        self.metadata()
            .ok()
            .and_then(|m| m.into_iter().find(|(n, _)| n == "aisle").map(|(_, m)| m))
            .unwrap_or_default()
    }

    /// Every metadata record (name -> entries) readable before any damage.
    pub fn metadata(&self) -> Result<Vec<MetadataRecord>, ReadError> {
        let mut out = Vec::new();
        self.scan_records(|r| {
            if let mcap::records::Record::Metadata(m) = r {
                out.push((m.name, m.metadata));
            }
        })?;
        Ok(out)
    }

    fn scan_records(&self, mut f: impl FnMut(mcap::records::Record<'_>)) -> Result<(), ReadError> {
        let reader = mcap::read::LinearReader::new_with_options(
            &self.buf,
            mcap::read::Options::IgnoreEndMagic.into(),
        )
        .map_err(|e| self.damaged(0, None, e))?;
        for r in reader {
            match r {
                Ok(mcap::records::Record::DataEnd(_)) => break,
                Ok(r) => f(r),
                Err(e) => return Err(self.damaged(0, None, e)),
            }
        }
        Ok(())
    }

    fn damaged(&self, messages: u64, last: Option<u64>, e: impl std::fmt::Display) -> ReadError {
        ReadError::Damaged {
            path: self.path.clone(),
            messages,
            last_log_time_ns: last,
            reason: e.to_string(),
        }
    }
}

/// Largest record or decompressed chunk the reader accepts (our chunks are 4 MiB plus
/// at most one message of under 2 MiB).
pub const MAX_RECORD_BYTES: usize = 256 << 20;

/// Iterator over the messages of a [`RecordFile`].
pub struct Messages<'a> {
    file: &'a RecordFile,
    reader: Option<mcap::sans_io::LinearReader>,
    fed: usize,
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, Arc<ChannelInfo>>,
    count: u64,
    last_log_time: Option<u64>,
    raw_only: bool,
}

enum Step {
    Message(FileMessage),
    Skip,
    End,
}

impl Messages<'_> {
    fn fail(&mut self, reason: String) -> Option<Result<FileMessage, ReadError>> {
        Some(Err(self.file.damaged(
            self.count,
            self.last_log_time,
            reason,
        )))
    }

    fn record(&mut self, opcode: u8, data: &[u8]) -> Result<Step, String> {
        use mcap::records::Record;
        match mcap::parse_record(opcode, data).map_err(|e| e.to_string())? {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => {
                let info = ChannelInfo {
                    id: c.id,
                    topic: c.topic,
                    message_encoding: c.message_encoding,
                    schema_name: self.schemas.get(&c.schema_id).cloned(),
                    metadata: c.metadata,
                };
                self.channels.insert(c.id, Arc::new(info));
            }
            Record::Message { header, data } => {
                let channel = self
                    .channels
                    .get(&header.channel_id)
                    .cloned()
                    .ok_or_else(|| {
                        format!(
                            "message {} on channel {} which was never declared",
                            header.sequence, header.channel_id
                        )
                    })?;
                if self.raw_only && !channel.is_raw() {
                    return Ok(Step::Skip);
                }
                // The payload out of its envelope (a message that is not one is damage).
                let mut data = if channel.enveloped() {
                    crate::envelope::unwrap(&data)
                        .map_err(|e| format!("{}: {e}", channel.topic))?
                        .to_vec()
                } else {
                    data.into_owned()
                };
                if let Some(size) = channel.padded_size()
                    && data.len() < size
                {
                    data.resize(size, 0);
                }
                return Ok(Step::Message(FileMessage {
                    channel,
                    sequence: header.sequence,
                    log_time: header.log_time,
                    publish_time: header.publish_time,
                    data,
                }));
            }
            Record::DataEnd(_) | Record::Footer(_) => return Ok(Step::End),
            _ => {}
        }
        Ok(Step::Skip)
    }
}

enum Action {
    End,
    Fail(String),
    Read(usize),
    Step(Result<Step, String>),
}

impl Iterator for Messages<'_> {
    type Item = Result<FileMessage, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        let mut reader = self.reader.take()?;
        loop {
            let action = match reader.next_event() {
                None => Action::End,
                Some(Err(e)) => Action::Fail(e.to_string()),
                Some(Ok(mcap::sans_io::LinearReadEvent::ReadRequest(need))) => Action::Read(need),
                Some(Ok(mcap::sans_io::LinearReadEvent::Record { data, opcode })) => {
                    Action::Step(self.record(opcode, data))
                }
            };
            match action {
                Action::End | Action::Step(Ok(Step::End)) => return None,
                Action::Fail(reason) | Action::Step(Err(reason)) => return self.fail(reason),
                Action::Read(need) => {
                    let buf = &self.file.buf;
                    let n = need.min(buf.len() - self.fed);
                    if n == 0 {
                        return self.fail(format!(
                            "the file is cut short at {} bytes (not finalised: the recorder \
                             was killed or the copy is incomplete)",
                            buf.len()
                        ));
                    }
                    reader
                        .insert(n)
                        .copy_from_slice(&buf[self.fed..self.fed + n]);
                    reader.notify_read(n);
                    self.fed += n;
                }
                Action::Step(Ok(Step::Skip)) => {}
                Action::Step(Ok(Step::Message(m))) => {
                    self.count += 1;
                    self.last_log_time = Some(m.log_time);
                    self.reader = Some(reader);
                    return Some(Ok(m));
                }
            }
        }
    }
}
