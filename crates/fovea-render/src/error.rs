//! Typed errors of the render crate, split by whose fault they are. Every message is one
//! printable line: control characters quoted from a file (a `\r` in an XML parser's message, a
//! NUL in a name) are shown escaped ([`printable`]).

use std::path::PathBuf;

use fovea_core::error::{echoed, printable};
use thiserror::Error;

/// Every error the render crate returns.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RenderError {
    /// A parameter outside its valid range (display, mapping, camera, light count…).
    #[error(transparent)]
    Core(#[from] fovea_core::FoveaError),
    /// A parameter of the renderer outside its valid range.
    #[error(
        "invalid parameter `{}` = {}: expected {}",
        echoed(.name),
        echoed(.value),
        printable(.expected)
    )]
    InvalidParameter {
        /// Parameter name as the user writes it.
        name: String,
        /// The offending value.
        value: String,
        /// What would be accepted.
        expected: String,
    },
    /// A file could not be read.
    #[error(
        "cannot read {}: {}",
        shown_path(.path),
        printable(.message)
    )]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// A file was read but its content is wrong (truncated, malformed, NaN vertices…).
    #[error(
        "bad scene file {}: {}",
        shown_path(.path),
        printable(.what)
    )]
    BadInput {
        /// The file.
        path: PathBuf,
        /// What is wrong, specific enough to fix it.
        what: String,
    },
    /// A feature of the input that the renderer does not support (e.g. Draco compression).
    #[error("unsupported: {}", printable(.0))]
    Unsupported(String),
    /// Another executor (e.g. the GPU) failed a stage; `message` says what to do.
    #[error("{stage} on the {backend} backend: {message}")]
    Executor {
        /// The stage.
        stage: &'static str,
        /// The backend's name.
        backend: String,
        /// Its one-line error.
        message: String,
    },
    /// A request that would exceed a resource limit, refused before allocating.
    #[error(
        "resource limit: {} needs {}, but the limit is {}",
        printable(.what),
        printable(.needed),
        printable(.limit)
    )]
    ResourceLimit {
        /// What was requested.
        what: String,
        /// How much it would need.
        needed: String,
        /// The limit in force.
        limit: String,
    },
}

/// A path for a message: displayed, control characters escaped.
fn shown_path(path: &std::path::Path) -> String {
    printable(&path.display().to_string()).into_owned()
}

/// Result alias of the render crate.
pub type Result<T> = std::result::Result<T, RenderError>;

impl RenderError {
    /// Shorthand for [`RenderError::InvalidParameter`].
    pub fn invalid(
        name: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        RenderError::InvalidParameter {
            name: name.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }

    /// Shorthand for [`RenderError::BadInput`].
    pub fn bad(path: impl Into<PathBuf>, what: impl Into<String>) -> Self {
        RenderError::BadInput {
            path: path.into(),
            what: what.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, err: &std::io::Error) -> Self {
        RenderError::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_one_printable_line() {
        // Found by fuzzing: roxmltree quotes the offending character, here a CR.
        let e = RenderError::bad("a\nb.xml", "malformed XML: expected '>' not '\r' at 1:18");
        assert_eq!(
            e.to_string(),
            "bad scene file a\\nb.xml: malformed XML: expected '>' not '\\r' at 1:18"
        );
        let e = RenderError::Unsupported("x\0y".into());
        assert_eq!(e.to_string(), "unsupported: x\\u{0}y");
        let e = RenderError::from(fovea_core::FoveaError::invalid("a\tb", "v\u{1b}", "ok"));
        assert_eq!(
            e.to_string(),
            "invalid parameter `a\\tb` = v\\u{1b}: expected ok"
        );
        // Unicode text stays as it is.
        let e = RenderError::bad("é.obj", "µs → °");
        assert_eq!(e.to_string(), "bad scene file é.obj: µs → °");
    }
}
