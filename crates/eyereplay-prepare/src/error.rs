use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    #[error("{path}: {message}")]
    Config { path: PathBuf, message: String },
    #[error("{id}: {message}")]
    Source { id: String, message: String },
    #[error("class '{class}': {message}")]
    Class { class: String, message: String },
    #[error(transparent)]
    Read(#[from] eyereplay_sources::SourceError),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
}

/// A dataset config's text that does not parse, or a config that does not
/// validate: one line, without the file's path ([`PrepareError::Config`]
/// adds it).
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The TOML or its keys: `line L, column C: message`, with a
    /// suggestion for a misspelt key.
    #[error("{0}")]
    Parse(String),
    /// A value out of range, or a class with nothing to draw from.
    #[error("{0}")]
    Invalid(String),
    /// A behaviour generator's table.
    #[error(transparent)]
    Generator(#[from] eyereplay_behaviour::BehaviourError),
}
