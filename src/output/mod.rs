//! What a solve writes: images from the camera (EXR linear, PNG gamma 2.2), the node cloud
//! (PLY), probe values (CSV) and stats.json.

pub mod image;
pub mod ply;
pub mod probe;

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Creates `dir` (and parents) if needed.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Writes `value` as pretty JSON to `path` (atomically, see [`Outputs`]).
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let mut o = Outputs::default();
    o.add(path, json_bytes(path, value)?);
    o.commit()
}

/// Writes `bytes` to `path` atomically (see [`Outputs`]).
pub fn write_bytes(path: &Path, bytes: Vec<u8>) -> Result<()> {
    let mut o = Outputs::default();
    o.add(path, bytes);
    o.commit()
}

/// `value` as pretty JSON text.
pub fn json_bytes<T: serde::Serialize>(path: &Path, value: &T) -> Result<Vec<u8>> {
    let text = serde_json::to_string_pretty(value).map_err(|e| Error::Output {
        path: path.into(),
        message: e.to_string(),
    })?;
    Ok((text + "\n").into_bytes())
}

/// The files one command writes, encoded in memory and written together at the end:
/// each to a temporary file beside its destination, then all renamed into place. A
/// failure (a full disk, a bad path) removes the temporary files and leaves every
/// destination as it was, so no output is ever half-written, and no stale file from an
/// earlier run is left beside new ones.
#[derive(Default)]
pub struct Outputs {
    files: Vec<(PathBuf, Vec<u8>)>,
}

impl Outputs {
    /// Adds a file to write.
    pub fn add(&mut self, path: impl Into<PathBuf>, bytes: Vec<u8>) {
        self.files.push((path.into(), bytes));
    }

    /// The destinations, in order.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|(p, _)| p.as_path())
    }

    /// Writes every file, or none.
    pub fn commit(self) -> Result<()> {
        let mut temps: Vec<(PathBuf, &Path)> = Vec::new();
        let cleanup = |temps: &[(PathBuf, &Path)]| {
            for (t, _) in temps {
                let _ = std::fs::remove_file(t);
            }
        };
        for (path, bytes) in &self.files {
            let tmp = temp_path(path);
            let written = std::fs::File::create(&tmp).and_then(|mut f| {
                use std::io::Write as _;
                f.write_all(bytes)?;
                f.sync_all()
            });
            if let Err(e) = written {
                let _ = std::fs::remove_file(&tmp);
                cleanup(&temps);
                return Err(Error::io(path, e));
            }
            temps.push((tmp, path));
        }
        for (k, (tmp, path)) in temps.iter().enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                cleanup(&temps[k..]);
                return Err(Error::io(*path, e));
            }
        }
        Ok(())
    }
}

/// A temporary name beside `path`: `.NAME.meshrad-PID.tmp`.
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.meshrad-{}.tmp", std::process::id()))
}

/// `path` made absolute with symbolic links resolved, also when the file does not exist
/// yet (its directory must); `None` when its directory does not exist either.
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    parent.canonicalize().ok().map(|d| d.join(name))
}

/// Whether two paths name the same file (the same resolved path, or the same inode).
fn same_file(a: &Path, b: &Path) -> bool {
    match (resolved(a), resolved(b)) {
        (Some(x), Some(y)) if x == y => return true,
        _ => {}
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    false
}

/// Checked before any work: every output's directory exists, no output is a directory,
/// no two outputs are the same file, and no output is one of `inputs`.
pub fn check_outputs(outputs: &[(&str, PathBuf)], inputs: &[PathBuf]) -> Result<()> {
    let bad = |p: &Path, m: String| Error::Output {
        path: p.into(),
        message: m,
    };
    for (k, (what, p)) in outputs.iter().enumerate() {
        if p.is_dir() {
            return Err(bad(p, format!("{what} is a directory, not a file")));
        }
        if resolved(p).is_none() {
            return Err(bad(p, format!("{what}: its directory does not exist")));
        }
        if let Some(i) = inputs.iter().find(|i| same_file(p, i)) {
            return Err(bad(
                p,
                format!("{what} would overwrite the input {}; choose another path", i.display()),
            ));
        }
        if let Some((other, _)) = outputs[..k].iter().find(|(_, q)| same_file(p, q)) {
            return Err(bad(
                p,
                format!("{what} is the same file as {other}; choose another path"),
            ));
        }
    }
    Ok(())
}
