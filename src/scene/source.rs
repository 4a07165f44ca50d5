//! Where scene files come from: a directory on disk, or the Cornell box embedded in the
//! binary (so that `meshrad` with no arguments works from anywhere).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::limits::MAX_MESH_BYTES;

/// The shipped Cornell box, embedded (whole, and in parts for editing).
pub const EMBEDDED_CORNELL: &[(&str, &[u8])] = &[
    ("cornell_box.toml", include_bytes!("../../scenes/cornell_box.toml")),
    ("cornell_parts.toml", include_bytes!("../../scenes/cornell_parts.toml")),
    ("cornell_area.toml", include_bytes!("../../scenes/cornell_area.toml")),
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

/// The environment variable that says where the public test scenes live (Sponza, the
/// Buddha, …; `scenes/README.md` says where each comes from).
pub const SCENES_VAR: &str = "MESHRAD_SCENES";
/// Its default, relative to the current directory (the repository root, for tests and
/// benchmarks run by cargo).
pub const SCENES_DEFAULT: &str = "../shared/scenes";

/// The folder of the public test scenes: `$MESHRAD_SCENES`, else `../shared/scenes`.
pub fn scenes_dir() -> PathBuf {
    match std::env::var_os(SCENES_VAR) {
        Some(v) if !v.is_empty() => PathBuf::from(v),
        _ => PathBuf::from(SCENES_DEFAULT),
    }
}

/// A mesh path of a scene file with a leading `$MESHRAD_SCENES/` (or
/// `${MESHRAD_SCENES}/`) replaced by [`scenes_dir`], made absolute so that it does not
/// depend on the scene file's folder; `None` when the path does not start with it.
pub fn expand_scenes_var(mesh: &str) -> Option<PathBuf> {
    let rest = ["$MESHRAD_SCENES/", "${MESHRAD_SCENES}/"]
        .iter()
        .find_map(|p| mesh.strip_prefix(p))?;
    let dir = scenes_dir();
    let dir = if dir.is_absolute() {
        dir
    } else {
        std::env::current_dir().map(|c| c.join(&dir)).unwrap_or(dir)
    };
    Some(dir.join(rest))
}
