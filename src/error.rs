//! The library's error type: every variant names the input (file, line, key) or the
//! call that failed, so that the CLI can print one clear sentence and exit non-zero.

use std::path::PathBuf;

/// All errors of the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written. (The OS error is part of this message and
    /// not a `source`, so that a printed chain does not repeat it.)
    #[error("{path}: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    /// The scene file is not valid TOML or does not match the schema.
    #[error("{path}: {message}")]
    SceneSyntax { path: PathBuf, message: String },
    /// A key of the scene file has an impossible value.
    #[error("{path}: key `{key}`: {message}")]
    SceneValue {
        path: PathBuf,
        key: String,
        message: String,
    },
    /// A mesh (OBJ) or material (MTL) file is malformed.
    #[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Mesh {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    /// A texture could not be decoded.
    #[error("{path}: texture: {message}")]
    Texture { path: PathBuf, message: String },
    /// A solver parameter (from the scene file or the command line) is impossible.
    #[error("parameter `{name}`: {message}")]
    Param { name: String, message: String },
    /// A points file for `probe` or `reference` is malformed.
    #[error("{path}:{line}: {message}")]
    Points {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A run would need more memory than it may plan for (see `limits`).
    #[error("{path}: key `{key}`: {message}")]
    Resource {
        path: PathBuf,
        key: String,
        message: String,
    },
    /// An edit of a frame or a session (`edit`) names what is not there or sets an
    /// impossible value: `at` is the frame or line, `key` the edited key.
    #[error("{at}: `{key}`: {message}")]
    Edit { at: String, key: String, message: String },
    /// The Vulkan layer failed.
    #[error("GPU: {0}")]
    Gpu(String),
    /// Writing an output file failed.
    #[error("{path}: {message}")]
    Output { path: PathBuf, message: String },
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            error: source,
        }
    }

    /// An impossible parameter value.
    pub fn param(name: &str, message: impl Into<String>) -> Self {
        Error::Param {
            name: name.to_string(),
            message: message.into(),
        }
    }
}
