//! A replay without a supervisor: it creates the instance itself (claims it, announces
//! this build's schema hash with the record's seed and clock mode, and so writes the
//! discovery file), publishes the record into it, and removes everything of it when the
//! replay ends, whether by the file's end, a stop request or an error. Consumers (a
//! Python script, `aisle echo`) find it by discovery and join it as they would a group.
//!
//! Knows the instance's life cycle; what is published and when is `replay.rs`'s.

use crate::reader::RecordFile;
use crate::replay::{ReplayError, ReplayOptions, ReplaySummary, publish_file};
use aisle_bus::owner::Owner;
use aisle_bus::{Bus, BusError};
use aisle_messages::TickMode;

/// Creates `opts.instance`, replays into it, removes it.
pub(crate) fn replay_own(
    opts: &ReplayOptions,
    file: &RecordFile,
    selected: &[String],
    foreign: Option<String>,
) -> Result<ReplaySummary, ReplayError> {
    let meta = file.run_metadata();
    let seed = meta.get("seed").and_then(|s| s.parse().ok()).unwrap_or(0);
    let mode = match meta.get("mode").map(String::as_str) {
        Some("1") => TickMode::Realtime,
        _ => TickMode::Lockstep,
    };
    if let Some(theirs) = &foreign {
        tracing::warn!(
            "{} was recorded by a build with message schema {theirs}, this build has {}: \
             every replayed service has this build's layout, so the instance announces {}",
            opts.file.display(),
            aisle_messages::schema_hash_hex(),
            aisle_messages::schema_hash_hex()
        );
    }
    let result = (|| {
        let (bus, announcement) = Bus::create_instance(&opts.instance, seed, mode)?;
        tracing::info!(
            "replay instance {} (root {}): join it with AISLE_PREFIX/AISLE_ROOT or by discovery",
            opts.instance.prefix,
            opts.instance.root.display()
        );
        publish_file(&bus, file, selected, opts, foreign, Some(&announcement))
    })();
    // Every port of the instance was this process's and is closed now. Only an
    // instance this process claimed is removed.
    let ours = Owner::read(&opts.instance.root).is_some_and(|o| Some(o) == Owner::current());
    let removed = if ours || !opts.instance.root.exists() {
        opts.instance.remove()
    } else {
        Ok(())
    };
    match (result, removed) {
        (Ok(_), Err(e)) => Err(ReplayError::Bus(BusError::Instance {
            prefix: opts.instance.prefix.clone(),
            what: format!("cannot remove it after the replay: {e}"),
        })),
        (r, _) => r,
    }
}
