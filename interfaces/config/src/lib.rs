//! Loading TOML configuration with errors a person can act on, and the warehouse scene.
//!
//! Every error names the file, the line and the key. Knows nothing of the bus or of the
//! processes that use the values; each crate owns and validates its own config struct and
//! reports problems through [`ConfigError::invalid`].

mod load;
pub mod scene;

pub use load::{ConfigError, load_toml, parse_toml};
