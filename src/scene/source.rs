//! Where scene files come from: a directory on disk, or the Cornell box embedded in the
//! binary (so that `meshrad` with no arguments works from anywhere).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::limits::MAX_MESH_BYTES;

/// The shipped Cornell box, embedded.
pub const EMBEDDED_CORNELL: &[(&str, &[u8])] = &[
    ("cornell_box.toml", include_bytes!("../../scenes/cornell_box.toml")),
    (
        "cornell_original_mm.obj",
        include_bytes!("../../scenes/cornell_original_mm.obj"),
    ),
    (
        "cornell_original_mm.mtl",
        include_bytes!("../../scenes/cornell_original_mm.mtl"),
    ),
];

/// A set of files addressed by paths relative to the scene file.
#[derive(Clone, Debug)]
pub enum Source {
    /// Files on disk, relative to this directory.
    Dir(PathBuf),
    /// Files compiled into the binary.
    Embedded(&'static [(&'static str, &'static [u8])]),
}

impl Source {
    /// The path shown in messages for `rel`.
    pub fn display(&self, rel: &Path) -> PathBuf {
        match self {
            Source::Dir(d) => d.join(rel),
            Source::Embedded(_) => Path::new("<embedded>").join(rel),
        }
    }

    /// Reads `rel` (at most [`MAX_MESH_BYTES`]).
    pub fn read(&self, rel: &Path) -> Result<Vec<u8>> {
        self.read_limited(rel, MAX_MESH_BYTES)
    }

    /// Reads `rel`, at most `limit` bytes (see [`crate::limits::read_file`]).
    pub fn read_limited(&self, rel: &Path, limit: u64) -> Result<Vec<u8>> {
        match self {
            Source::Dir(d) => crate::limits::read_file(&d.join(rel), limit),
            Source::Embedded(files) => {
                let key = rel.to_string_lossy().replace('\\', "/");
                let key = key.trim_start_matches("./");
                files
                    .iter()
                    .find(|(name, _)| *name == key)
                    .map(|(_, b)| b.to_vec())
                    .ok_or_else(|| {
                        Error::io(
                            self.display(rel),
                            std::io::Error::new(std::io::ErrorKind::NotFound, "not embedded"),
                        )
                    })
            }
        }
    }
}
