//! The live view: serves the viewer channels of a running group over the Foxglove
//! WebSocket protocol (the `foxglove` crate's server; its subprotocol is named
//! `foxglove.sdk.v1`, the message framing that of `foxglove.websocket.v1`), so
//! Foxglove or Lichtblick connected to `ws://ADDR` watch the run as it happens.
//!
//! The channels, schemas and message bytes are the record's own viewer channels
//! ([`crate::viewer`]): whoever converts for the record offers the same messages here.
//! Serving never holds the caller up: [`LiveServer::offer`] puts a message in a bounded
//! queue and returns; when the queue is full the message is dropped and counted. A
//! dedicated thread hands queued messages to the server, whose per-client outboxes drop
//! the oldest messages for a client that reads too slowly (the crate logs that). The
//! channels that change rarely (scene, global map, reference path, robot model:
//! [`ViewerTopic::latched`]) are latched: a client that subscribes late gets their newest
//! message at once. Each channel is declared with its topic's own encoding and schema
//! (protobuf or JSON), as in the record. Knows nothing of the bus or
//! of files.

use crate::viewer::{ViewerMessage, ViewerTopic};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, WebSocketServer};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// The address `aisle run --foxglove` serves on when none is given.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

/// Messages that may wait for the serving thread; beyond, new ones are dropped.
const QUEUE_MESSAGES: usize = 4096;

/// Messages each client may have waiting in the server before the oldest are dropped.
const CLIENT_BACKLOG: usize = 2048;

/// The newest message of each latched channel, re-sent to whoever subscribes to it.
#[derive(Default)]
struct Latch {
    channels: Vec<Arc<RawChannel>>,
    newest: Mutex<Vec<Option<Vec<u8>>>>,
}

impl Latch {
    fn keep(&self, msg: &ViewerMessage) {
        if msg.topic.latched()
            && let Ok(mut newest) = self.newest.lock()
        {
            newest[msg.topic.index()] = Some(msg.data.clone());
        }
    }
}

impl ServerListener for Latch {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let Some(i) = self.channels.iter().position(|c| c.id() == channel.id()) else {
            return;
        };
        let data = self.newest.lock().ok().and_then(|n| n[i].clone());
        if let Some(data) = data {
            self.channels[i].log_to_sink(&data, client.sink_id());
        }
    }
}

/// Why the live view could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error("--foxglove {addr}: cannot serve there: {source}")]
    Serve {
        addr: SocketAddr,
        source: foxglove::FoxgloveError,
    },
    #[error("--foxglove: channel {topic}: {source}")]
    Channel {
        topic: &'static str,
        source: foxglove::FoxgloveError,
    },
    #[error("--foxglove: the serving thread: {0}")]
    Thread(std::io::Error),
}

/// What the live view served over the run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LiveSummary {
    /// Messages handed to the server (each goes to every subscribed client).
    pub served: u64,
    /// Messages dropped because the serving thread fell behind.
    pub dropped: u64,
}

/// A running live view.
pub struct LiveServer {
    queue: SyncSender<(ViewerMessage, u64)>,
    dropped: u64,
    served: Arc<AtomicU64>,
    addr: SocketAddr,
    thread: JoinHandle<()>,
}

impl LiveServer {
    /// Binds `addr` and starts serving the viewer channels (no client needed).
    pub fn start(addr: SocketAddr) -> Result<LiveServer, LiveError> {
        let ctx = Context::new();
        let channels = ViewerTopic::ALL
            .iter()
            .map(|t| {
                ChannelBuilder::new(t.topic())
                    .context(&ctx)
                    .schema(t.schema())
                    .message_encoding(t.encoding())
                    .build_raw()
                    .map_err(|source| LiveError::Channel {
                        topic: t.topic(),
                        source,
                    })
            })
            .collect::<Result<Vec<Arc<RawChannel>>, LiveError>>()?;
        let latch = Arc::new(Latch {
            channels: channels.clone(),
            newest: Mutex::new(vec![None; channels.len()]),
        });
        let server = WebSocketServer::new()
            .name("aisle")
            .context(&ctx)
            .listener(latch.clone())
            .message_backlog_size(CLIENT_BACKLOG)
            .bind(addr.ip().to_string(), addr.port())
            .start_blocking()
            .map_err(|source| LiveError::Serve { addr, source })?;
        let bound = SocketAddr::new(addr.ip(), server.port());
        let (queue, rx) = mpsc::sync_channel::<(ViewerMessage, u64)>(QUEUE_MESSAGES);
        let served = Arc::new(AtomicU64::new(0));
        let count = served.clone();
        let thread = std::thread::Builder::new()
            .name("foxglove-live".into())
            .spawn(move || {
                for (msg, log_time) in rx {
                    latch.keep(&msg);
                    let meta = PartialMetadata::with_log_time(log_time);
                    channels[msg.topic.index()].log_with_meta(&msg.data, meta);
                    count.fetch_add(1, Ordering::Relaxed);
                }
                // The run is over: close the connections (the context, which owns the
                // channels, lives until then).
                drop(server.stop());
                drop(ctx);
            })
            .map_err(LiveError::Thread)?;
        Ok(LiveServer {
            queue,
            dropped: 0,
            served,
            addr: bound,
            thread,
        })
    }

    /// The address served (with the port the OS chose when `addr` asked for port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Offers one viewer message stamped `log_time_ns`; never blocks.
    pub fn offer(&mut self, msg: &ViewerMessage, log_time_ns: u64) {
        match self.queue.try_send((msg.clone(), log_time_ns)) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => self.dropped += 1,
        }
    }

    /// Stops serving (after the queued messages went out); returns what was served.
    pub fn finish(self) -> LiveSummary {
        let LiveServer {
            queue,
            dropped,
            served,
            thread,
            ..
        } = self;
        drop(queue);
        let _ = thread.join();
        LiveSummary {
            served: served.load(Ordering::Relaxed),
            dropped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serves_on_a_free_port_and_counts_what_it_served() {
        let mut live = LiveServer::start("127.0.0.1:0".parse().unwrap()).unwrap();
        assert_ne!(live.addr().port(), 0);
        let msg = ViewerMessage {
            topic: ViewerTopic::Log,
            stamp_ns: 1,
            data: vec![],
        };
        for _ in 0..10 {
            live.offer(&msg, 1);
        }
        let s = live.finish();
        assert_eq!(s.served + s.dropped, 10);
    }

    #[test]
    fn a_taken_address_is_an_error_naming_it() {
        let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = taken.local_addr().unwrap();
        let e = LiveServer::start(addr).err().expect("bind must fail");
        assert!(e.to_string().contains(&addr.to_string()), "{e}");
    }
}
