//! The one error type of the core. Every fallible entry point returns it; the
//! binding maps it to Python exceptions in a single `From` impl.

use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// An argument is malformed (wrong length, non-finite, out of range).
    #[error("invalid argument `{name}`: {reason}")]
    InvalidArgument { name: &'static str, reason: String },

    /// The potential and the state disagree in dimension.
    #[error("the potential expects {expected} coordinates but the state has {got}")]
    DimensionMismatch { expected: usize, got: usize },

    /// A user-supplied potential (a Python callback) failed; the text is its message.
    #[error("the potential failed: {0}")]
    Potential(String),

    /// The potential was asked to stop (Ctrl-C inside a Python callback): the run ends
    /// "interrupted" at its last observed state, keeping its samples.
    #[error("interrupted")]
    Interrupted,
}

impl CoreError {
    pub fn invalid(name: &'static str, reason: impl Into<String>) -> Self {
        CoreError::InvalidArgument {
            name,
            reason: reason.into(),
        }
    }
}

pub type CoreResult<T> = Result<T, CoreError>;
