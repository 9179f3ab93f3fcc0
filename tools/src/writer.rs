//! Writes an aisle MCAP file: one raw channel per service (payload bytes exactly as in
//! shared memory, in a protobuf envelope), the Foxglove viewer channels, attachments and
//! metadata.
//!
//! Raw channels: message encoding `protobuf`, each payload inside a one-field message
//! (`bytes data = 1`, [`crate::envelope`]) whose schema is named by the message type
//! (a protobuf `FileDescriptorSet`), channel metadata [`RAW_KEY`] = [`RAW_ENVELOPE`]
//! (what marks a raw channel), `type_name`, `size`, `align`, `layout_hash` (per type),
//! `schema_hash` (all types, as `aisle_messages::schema_hash_hex()`) and `layout` (the
//! field layout as text). Each message: `log_time` as the caller gives it (the recorder:
//! sim time in lockstep, Unix receive time in realtime, see `record::log_clock`),
//! `publish_time` = the header's `stamp_ns`, `sequence` = the header's `seq` (truncated
//! to 32 bits). This module knows the file format, not the bus.
//!
//! Why the envelope: Foxglove and Lichtblick parse every channel of a file when it
//! opens and report any encoding but `json`, `protobuf`, `flatbuffer`, `ros1` and `cdr`
//! as a problem ("Unsupported encoding"), whatever the channel's metadata says
//! (Lichtblick's `parseChannel`), so the raw channels, written with their own encoding
//! `aisle-raw` before, showed as 18 problems. Moving them into a companion file would
//! change every reader and split a run in two; an encoding Foxglove knows, with bytes
//! that are not in it, would fail every decoder. The envelope is real protobuf (a
//! viewer shows each raw message as one `data` bytes field) and costs two to four bytes
//! a message; the reader strips it ([`crate::reader`]), and still reads records with
//! the older `aisle-raw` channels ([`LEGACY_RAW_ENCODING`]).
//!
//! Viewer channels: each [`ViewerTopic`] with its own encoding and schema (Foxglove
//! protobuf, or JSON with a JSON Schema for the plots).

use crate::catalog::{ServiceInfo, services};
use crate::payload_fields::{SEQ_AT, STAMP_AT, u64_at};
use crate::viewer::{ViewerMessage, ViewerTopic};
use mcap::records::MessageHeader;
use std::collections::BTreeMap;
use std::io::{Seek, Write};

/// Message encoding of the raw channels: each payload in a protobuf envelope.
pub const RAW_ENCODING: &str = "protobuf";
/// Raw channel metadata key (and its value) that marks a raw channel.
pub const RAW_KEY: &str = "aisle_raw";
pub const RAW_ENVELOPE: &str = "protobuf_envelope";
/// Message encoding of the raw channels of older records (payloads without envelope).
pub const LEGACY_RAW_ENCODING: &str = "aisle-raw";
/// The MCAP header profile.
pub const PROFILE: &str = "aisle";
/// Raw channel metadata key: `true` when payloads are stored without trailing zeros.
pub const TRIMMED_KEY: &str = "trailing_zeros_trimmed";

#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("mcap: {}", mcap_detail(.0))]
    Mcap(#[from] mcap::McapError),
    #[error("`{service}` is not a recorded service")]
    UnknownService { service: String },
    #[error("service `{service}`: payload of {got} bytes, {type_name} has {want}")]
    WrongSize {
        service: String,
        type_name: &'static str,
        got: usize,
        want: usize,
    },
    #[error("no Foxglove schema for viewer topic {0}")]
    NoSchema(&'static str),
}

/// The MCAP error with its OS cause: the crate's own text for I/O errors drops it
/// ("I/O error from writing"), and "no space left on device" is what a user needs.
fn mcap_detail(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => format!("{e}: {io}"),
        other => other.to_string(),
    }
}

/// Compression of the chunks. Measured on a seed-sized tick (benches/record.rs, raw
/// payloads trimmed): Zstd 1.3 ms, Lz4 2.6 ms, None 0.3 ms per tick; so Zstd is the
/// default (it also makes the smallest files).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    None,
    Lz4,
    #[default]
    Zstd,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriterOptions {
    pub compression: Compression,
    /// Uncompressed bytes per chunk.
    pub chunk_size: u64,
    /// Store raw payloads without their trailing zero bytes (the unused capacity of
    /// clouds, grids and paths, which is zero-filled on publish). Lossless: the channel
    /// metadata says `trailing_zeros_trimmed = true` and gives `size`, and the reader
    /// pads the payload back to `size` bytes, so what it returns (and what replay
    /// publishes) is byte-identical to shared memory. Cuts a seed-sized point cloud from
    /// 1.57 MB to 0.45 MB, and the time to compress it by about as much.
    pub trim_trailing_zeros: bool,
}

impl Default for WriterOptions {
    fn default() -> Self {
        Self {
            compression: Compression::default(),
            chunk_size: 4 * 1024 * 1024,
            trim_trailing_zeros: true,
        }
    }
}

/// Counts of what was written, per raw service.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WriteCounts {
    pub raw: BTreeMap<&'static str, u64>,
    pub viewer: u64,
    pub attachments: u64,
}

pub struct RecordWriter<W: Write + Seek> {
    mcap: mcap::Writer<W>,
    raw: Vec<(ServiceInfo, u16)>,
    viewer: Vec<u16>,
    counts: WriteCounts,
    trim: bool,
    /// The envelope of the raw message being written, reused.
    envelope: Vec<u8>,
}

/// Length of `bytes` without its trailing zeros (compares eight bytes at a time).
pub fn trimmed_len(bytes: &[u8]) -> usize {
    let mut end = bytes.len();
    while end >= 8 && bytes[end - 8..end] == [0u8; 8] {
        end -= 8;
    }
    while end > 0 && bytes[end - 1] == 0 {
        end -= 1;
    }
    end
}

/// The layout of a type as text: one `name: type @ offset +size` line per field.
pub fn layout_text(type_name: &str) -> String {
    let mut text = String::new();
    for (name, size, align, fields) in aisle_messages::all_layouts() {
        if name == type_name {
            text.push_str(&format!("{name} size {size} align {align}\n"));
            for f in fields {
                text.push_str(&format!(
                    "{}: {} @ {} +{}\n",
                    f.name, f.ty, f.offset, f.size
                ));
            }
        }
    }
    text
}

impl<W: Write + Seek> RecordWriter<W> {
    /// Starts a file and declares every raw and viewer channel.
    pub fn new(w: W, options: WriterOptions) -> Result<Self, WriteError> {
        let compression = match options.compression {
            Compression::None => None,
            Compression::Lz4 => Some(mcap::Compression::Lz4),
            Compression::Zstd => Some(mcap::Compression::Zstd),
        };
        let mut mcap = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(format!("aisle-tools {}", env!("CARGO_PKG_VERSION")))
            .compression(compression)
            // Compress in the writing thread, no zstd worker: the recorder's writer runs
            // at idle priority and hands its work to the node thread at the end of a run
            // (`record::write`); a worker it had started would stay idle-priority, and
            // starve under load with the rest of the record in it.
            .compression_threads(0)
            .chunk_size(Some(options.chunk_size))
            .create(w)?;
        let schema_hash = aisle_messages::schema_hash_hex();
        let mut raw = Vec::new();
        for info in services() {
            let (name, descriptor) = crate::envelope::schema(info.type_name);
            let schema = mcap.add_schema(&name, "protobuf", &descriptor)?;
            let meta = BTreeMap::from([
                (RAW_KEY.to_string(), RAW_ENVELOPE.to_string()),
                ("layout".to_string(), layout_text(info.type_name)),
                ("type_name".to_string(), info.type_name.to_string()),
                ("size".to_string(), info.size.to_string()),
                ("align".to_string(), info.align.to_string()),
                ("layout_hash".to_string(), info.layout_hash_hex()),
                ("schema_hash".to_string(), schema_hash.clone()),
                (
                    TRIMMED_KEY.to_string(),
                    options.trim_trailing_zeros.to_string(),
                ),
            ]);
            let id = mcap.add_channel(schema, info.service, RAW_ENCODING, &meta)?;
            raw.push((info, id));
        }
        let mut viewer = Vec::new();
        for topic in ViewerTopic::ALL {
            let schema = topic.schema().ok_or(WriteError::NoSchema(topic.topic()))?;
            let sid = mcap.add_schema(&schema.name, &schema.encoding, &schema.data)?;
            viewer.push(mcap.add_channel(
                sid,
                topic.topic(),
                topic.encoding(),
                &BTreeMap::new(),
            )?);
        }
        Ok(Self {
            mcap,
            raw,
            viewer,
            counts: WriteCounts::default(),
            trim: options.trim_trailing_zeros,
            envelope: Vec::new(),
        })
    }

    /// Index of `service` in the catalogue, for [`Self::write_raw_at`].
    pub fn service_index(&self, service: &str) -> Option<usize> {
        self.raw.iter().position(|(i, _)| i.service == service)
    }

    /// Writes one received payload of `service`, received at `log_time_ns`.
    pub fn write_raw(
        &mut self,
        service: &str,
        log_time_ns: u64,
        payload: &[u8],
    ) -> Result<(), WriteError> {
        let index = self
            .service_index(service)
            .ok_or_else(|| WriteError::UnknownService {
                service: service.to_string(),
            })?;
        self.write_raw_at(index, log_time_ns, payload)
    }

    /// Like [`Self::write_raw`] with the catalogue index of the service.
    pub fn write_raw_at(
        &mut self,
        index: usize,
        log_time_ns: u64,
        payload: &[u8],
    ) -> Result<(), WriteError> {
        let Some((info, channel_id)) = self.raw.get(index) else {
            return Err(WriteError::UnknownService {
                service: format!("#{index}"),
            });
        };
        if payload.len() != info.size {
            return Err(WriteError::WrongSize {
                service: info.service.to_string(),
                type_name: info.type_name,
                got: payload.len(),
                want: info.size,
            });
        }
        // Every message starts with the header.
        let header = MessageHeader {
            channel_id: *channel_id,
            sequence: u64_at(payload, SEQ_AT) as u32,
            log_time: log_time_ns,
            publish_time: u64_at(payload, STAMP_AT),
        };
        let stored = if self.trim {
            &payload[..trimmed_len(payload)]
        } else {
            payload
        };
        crate::envelope::wrap(stored, &mut self.envelope);
        self.mcap.write_to_known_channel(&header, &self.envelope)?;
        *self.counts.raw.entry(info.service).or_default() += 1;
        Ok(())
    }

    /// Writes a viewer message received (or converted) at `log_time_ns`.
    pub fn write_viewer(
        &mut self,
        msg: &ViewerMessage,
        log_time_ns: u64,
    ) -> Result<(), WriteError> {
        let header = MessageHeader {
            channel_id: self.viewer[msg.topic.index()],
            sequence: 0,
            log_time: log_time_ns,
            publish_time: msg.stamp_ns,
        };
        self.mcap.write_to_known_channel(&header, &msg.data)?;
        self.counts.viewer += 1;
        Ok(())
    }

    /// Attaches a file's content (a config file).
    pub fn attach(
        &mut self,
        name: &str,
        media_type: &str,
        data: &[u8],
        time_ns: u64,
    ) -> Result<(), WriteError> {
        self.mcap.attach(&mcap::Attachment {
            log_time: time_ns,
            create_time: time_ns,
            name: name.to_string(),
            media_type: media_type.to_string(),
            data: std::borrow::Cow::Borrowed(data),
        })?;
        self.counts.attachments += 1;
        Ok(())
    }

    pub fn write_metadata(
        &mut self,
        name: &str,
        entries: BTreeMap<String, String>,
    ) -> Result<(), WriteError> {
        self.mcap.write_metadata(&mcap::records::Metadata {
            name: name.to_string(),
            metadata: entries,
        })?;
        Ok(())
    }

    /// Closes the current chunk and flushes it to the file (a point from which a crash
    /// still leaves a readable prefix).
    pub fn flush(&mut self) -> Result<(), WriteError> {
        self.mcap.flush()?;
        Ok(())
    }

    pub fn counts(&self) -> &WriteCounts {
        &self.counts
    }

    /// Writes the summary and footer and returns the underlying writer.
    pub fn finish(mut self) -> Result<(W, WriteCounts), WriteError> {
        self.mcap.finish()?;
        let counts = std::mem::take(&mut self.counts);
        Ok((self.mcap.into_inner(), counts))
    }
}

/// Media type of a config file, from its extension.
pub fn media_type(path: &std::path::Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()) {
        Some("toml") => "application/toml",
        Some("urdf") | Some("xml") => "application/xml",
        Some("yaml") | Some("yml") => "application/yaml",
        Some("json") => "application/json",
        Some("pgm") => "image/x-portable-graymap",
        Some("png") => "image/png",
        Some("txt") | Some("md") => "text/plain",
        _ => "application/octet-stream",
    }
}
