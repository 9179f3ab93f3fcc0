//! Bus errors: every variant names the service or the instance it concerns.

#[derive(Debug, thiserror::Error)]
pub enum BusError {
    #[error("iceoryx2 instance `{prefix}`: {what}")]
    Instance { prefix: String, what: String },
    #[error("service `{service}`: {what}")]
    Service { service: String, what: String },
    #[error(
        "schema mismatch: this process was built with message schema {ours}, the supervisor of instance `{prefix}` with {theirs}; rebuild both from the same source"
    )]
    SchemaMismatch {
        ours: String,
        theirs: String,
        prefix: String,
    },
    #[error(
        "no instance `{prefix}` under {root}: {what}; is its group running? (`aisle run` logs the --prefix and --root of its instance)"
    )]
    NoInstance {
        prefix: String,
        root: std::path::PathBuf,
        what: String,
    },
    #[error("no supervisor answered on instance `{prefix}` within {waited_ms} ms")]
    NoSupervisor { prefix: String, waited_ms: u64 },
    #[error("stop requested")]
    StopRequested,
}

impl BusError {
    pub(crate) fn service(service: &str, what: impl std::fmt::Debug) -> Self {
        BusError::Service {
            service: service.to_string(),
            what: format!("{what:?}"),
        }
    }
}
