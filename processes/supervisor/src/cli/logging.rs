//! The log lines' subscriber (`tracing`, filtered by `AISLE_LOG`, on stderr) and
//! whether they carry ANSI colour (`--color`). Knows nothing of what is logged.

use std::io::IsTerminal;

/// `--color`: colour codes in log lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Color {
    /// When stderr is a terminal and `NO_COLOR` is unset or empty.
    Auto,
    /// Always, also into a file or a pipe.
    Always,
    /// Never.
    Never,
}

impl Color {
    /// Whether log lines get ANSI codes, given the environment.
    pub fn ansi(self, stderr_is_terminal: bool, no_color: Option<&std::ffi::OsStr>) -> bool {
        match self {
            Color::Always => true,
            Color::Never => false,
            // https://no-color.org: set and not empty means no colour.
            Color::Auto => stderr_is_terminal && no_color.is_none_or(|v| v.is_empty()),
        }
    }
}

/// Logs to stderr at `default` level unless `AISLE_LOG` says otherwise.
pub fn init_logging(default: &str, color: Color) {
    let filter = tracing_subscriber::EnvFilter::try_from_env("AISLE_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let ansi = color.ansi(
        std::io::stderr().is_terminal(),
        std::env::var_os("NO_COLOR").as_deref(),
    );
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .with_target(false)
        .try_init();
}

#[cfg(test)]
mod tests {
    use super::Color;
    use std::ffi::OsStr;

    #[test]
    fn colour_only_on_a_terminal_without_no_color() {
        assert!(Color::Auto.ansi(true, None));
        assert!(Color::Auto.ansi(true, Some(OsStr::new(""))));
        assert!(!Color::Auto.ansi(true, Some(OsStr::new("1"))));
        assert!(!Color::Auto.ansi(false, None));
        assert!(Color::Always.ansi(false, Some(OsStr::new("1"))));
        assert!(!Color::Never.ansi(true, None));
    }
}
