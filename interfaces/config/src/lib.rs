//! Loading TOML configuration with errors a person can act on, and the warehouse scene.
//!
//! The contract every config type follows: it derives `Deserialize` with
//! `deny_unknown_fields` (a typo is an error, not a silent default), implements
//! [`Validate`] (the first bad value as an [`InvalidKey`], using the shared [`checks`]),
//! and is read with [`load`] (or [`parse`] for text in memory). Every error then names
//! the file, the line and the key ([`ConfigError`]).
//!
//! Knows nothing of the bus or of the processes that use the values; each crate owns
//! its config struct and what makes its values valid.

pub mod checks;
mod load;
mod read;
pub mod scene;
pub mod scene_gen;
pub mod testing;

pub use checks::InvalidKey;
pub use load::{ConfigError, Validate, load, load_toml, parse, parse_toml};
pub use read::{MAX_CONFIG_BYTES, read_capped, read_capped_with};
