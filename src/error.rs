//! Errors of the renderer and the process exit codes they map to.

use thiserror::Error;

/// Process exit codes, documented in the README and in `docs/contract.md`.
pub mod exit_code {
    /// Success: the output was written.
    pub const OK: i32 = 0;
    /// A bug in Caustic.
    pub const INTERNAL: i32 = 1;
    /// Invalid command line or settings.
    pub const USAGE: i32 = 2;
    /// Invalid or unsupported scene.
    pub const BAD_SCENE: i32 = 3;
    /// Input unreadable or output not writable.
    pub const IO: i32 = 4;
    /// Interrupted; the partial image was written.
    pub const INTERRUPTED_PARTIAL: i32 = 5;
    /// Interrupted before any sample was rendered; nothing written.
    pub const INTERRUPTED_EMPTY: i32 = 6;
    /// The scene or settings would need more memory than `--memory-limit` allows; nothing written.
    pub const MEMORY: i32 = 7;
}

/// Everything that can make a command fail.
#[derive(Debug, Error)]
pub enum Error {
    /// The scene file is malformed or uses something Caustic refuses.
    #[error("{file}: {message}")]
    Scene { file: String, message: String },
    /// Reading the input or writing the output failed.
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    /// A setting is out of range or contradicts another.
    #[error("{0}")]
    Usage(String),
    /// The render was interrupted before any sample reached the film.
    #[error("interrupted before any sample was rendered; nothing written")]
    InterruptedEmpty,
    /// The estimated memory of the scene or settings exceeds the budget.
    #[error("not enough memory: {0}")]
    Memory(String),
    /// A bug.
    #[error("internal error: {0}")]
    Internal(String),
}

impl Error {
    /// The exit code this error ends the process with.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene { .. } => exit_code::BAD_SCENE,
            Error::Io { .. } => exit_code::IO,
            Error::Usage(_) => exit_code::USAGE,
            Error::InterruptedEmpty => exit_code::INTERRUPTED_EMPTY,
            Error::Memory(_) => exit_code::MEMORY,
            Error::Internal(_) => exit_code::INTERNAL,
        }
    }

    /// Shorthand for an I/O error on a path.
    pub fn io(path: impl AsRef<std::path::Path>, e: impl std::fmt::Display) -> Self {
        Error::Io { path: path.as_ref().display().to_string(), message: e.to_string() }
    }
}

/// Result with the renderer's error.
pub type Result<T> = std::result::Result<T, Error>;
