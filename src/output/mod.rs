//! What a solve writes: images from the camera (EXR linear, PNG gamma 2.2), the node cloud
//! (PLY), probe values (CSV) and stats.json.

pub mod image;
pub mod ply;
pub mod probe;

use std::path::Path;

use crate::error::{Error, Result};

/// Creates `dir` (and parents) if needed.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Writes `value` as pretty JSON to `path`.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| Error::Output {
        path: path.into(),
        message: e.to_string(),
    })?;
    std::fs::write(path, text + "\n").map_err(|e| Error::io(path, e))
}
