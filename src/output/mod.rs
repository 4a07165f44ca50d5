//! What a solve writes: images from the camera (EXR linear, PNG gamma 2.2), the node cloud
//! (PLY), probe values (CSV) and stats.json.

pub mod dark;
pub mod image;
pub mod ply;
pub mod probe;

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Creates `dir` (and parents) if needed.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Output {
            path: dir.into(),
            message: "is a file, not a directory: the outputs go into a directory; name another".into(),
        });
    }
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

    /// Writes every file, or none: each is written to a temporary file beside its
    /// destination, then the temporaries are moved into place, an existing destination
    /// first moved aside; if any move fails, those done are undone (the earlier files
    /// back in place), so the set on disk is the old one or the new one, never a mix.
    pub fn commit(self) -> Result<()> {
        self.commit_failing_at(None)
    }

    /// [`Outputs::commit`], with the move of file `fail` failing (tests of the undo).
    fn commit_failing_at(self, fail: Option<usize>) -> Result<()> {
        let mut temps: Vec<(PathBuf, &Path)> = Vec::new();
        let cleanup = |temps: &[(PathBuf, &Path)]| {
            for (t, _) in temps {
                let _ = std::fs::remove_file(t);
            }
        };
        for (path, bytes) in &self.files {
            let tmp = temp_path(path, "tmp");
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
        // (destination, where its earlier file was moved) for every move done.
        let mut done: Vec<(&Path, Option<PathBuf>)> = Vec::new();
        for (k, (tmp, path)) in temps.iter().enumerate() {
            let moved = (|| -> std::io::Result<Option<PathBuf>> {
                let old = match std::fs::symlink_metadata(path) {
                    Ok(_) => {
                        let old = temp_path(path, "old");
                        std::fs::rename(path, &old)?;
                        Some(old)
                    }
                    Err(_) => None,
                };
                let r = if fail == Some(k) {
                    Err(std::io::Error::other("a move made to fail (test)"))
                } else {
                    std::fs::rename(tmp, path)
                };
                if let Err(e) = r {
                    if let Some(o) = &old {
                        let _ = std::fs::rename(o, path);
                    }
                    return Err(e);
                }
                Ok(old)
            })();
            match moved {
                Ok(old) => done.push((path, old)),
                Err(e) => {
                    for (p, old) in done.iter().rev() {
                        match old {
                            Some(o) => {
                                let _ = std::fs::rename(o, p);
                            }
                            None => {
                                let _ = std::fs::remove_file(p);
                            }
                        }
                    }
                    cleanup(&temps[k..]);
                    return Err(Error::io(*path, e));
                }
            }
        }
        for (_, old) in done {
            if let Some(o) = old {
                let _ = std::fs::remove_file(o);
            }
        }
        Ok(())
    }
}

/// A temporary name beside `path`: `.NAME.meshrad-PID.EXT`.
fn temp_path(path: &Path, ext: &str) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.meshrad-{}.{ext}", std::process::id()))
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

/// What identifies a file: its resolved path, and its device and inode where it exists.
fn file_keys(p: &Path) -> (Option<PathBuf>, Option<(u64, u64)>) {
    #[cfg(unix)]
    let inode = {
        use std::os::unix::fs::MetadataExt as _;
        std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
    };
    #[cfg(not(unix))]
    let inode = None;
    (resolved(p), inode)
}

/// Checked before any work: every output's directory exists, no output is a directory,
/// no two outputs are the same file, and no output is one of `inputs` (the same file:
/// the same resolved path, or the same inode). Linear in the number of outputs (an
/// `animate` of thousands of frames plans thousands).
pub fn check_outputs(outputs: &[(&str, PathBuf)], inputs: &[PathBuf]) -> Result<()> {
    use std::collections::HashMap;
    let bad = |p: &Path, m: String| Error::Output {
        path: p.into(),
        message: m,
    };
    let mut input_paths: HashMap<PathBuf, usize> = HashMap::new();
    let mut input_inodes: HashMap<(u64, u64), usize> = HashMap::new();
    for (i, p) in inputs.iter().enumerate() {
        let (r, n) = file_keys(p);
        if let Some(r) = r {
            input_paths.entry(r).or_insert(i);
        }
        if let Some(n) = n {
            input_inodes.entry(n).or_insert(i);
        }
    }
    let mut paths: HashMap<PathBuf, usize> = HashMap::new();
    let mut inodes: HashMap<(u64, u64), usize> = HashMap::new();
    for (k, (what, p)) in outputs.iter().enumerate() {
        if p.is_dir() {
            return Err(bad(p, format!("{what} is a directory, not a file")));
        }
        let (r, n) = file_keys(p);
        let Some(r) = r else {
            return Err(bad(p, format!("{what}: its directory does not exist")));
        };
        let input = input_paths.get(&r).or_else(|| n.and_then(|n| input_inodes.get(&n)));
        if let Some(&i) = input {
            return Err(bad(
                p,
                format!(
                    "{what} would overwrite the input {}; choose another path",
                    inputs[i].display()
                ),
            ));
        }
        let earlier = paths.get(&r).or_else(|| n.and_then(|n| inodes.get(&n)));
        if let Some(&j) = earlier {
            return Err(bad(
                p,
                format!("{what} is the same file as {}; choose another path", outputs[j].0),
            ));
        }
        paths.insert(r, k);
        if let Some(n) = n {
            inodes.insert(n, k);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    /// Issue #35: a move that fails midway undoes the moves before it: the earlier
    /// outputs are back as they were, the new ones gone, no temporary left.
    #[test]
    fn a_failed_commit_leaves_the_earlier_set() {
        let dir = tempfile::tempdir().unwrap();
        let p = |n: &str| dir.path().join(n);
        std::fs::write(p("a.png"), "old a").unwrap();
        std::fs::write(p("c.json"), "old c").unwrap();
        let set = || {
            let mut o = super::Outputs::default();
            o.add(p("a.png"), b"new a".to_vec());
            o.add(p("b.exr"), b"new b".to_vec());
            o.add(p("c.json"), b"new c".to_vec());
            o
        };
        assert!(set().commit_failing_at(Some(2)).is_err());
        assert_eq!(std::fs::read_to_string(p("a.png")).unwrap(), "old a");
        assert!(!p("b.exr").exists());
        assert_eq!(std::fs::read_to_string(p("c.json")).unwrap(), "old c");
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["a.png", "c.json"]);
        set().commit().unwrap();
        assert_eq!(std::fs::read_to_string(p("c.json")).unwrap(), "new c");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3);
    }

    /// Issue #35: an `animate` of thousands of frames plans thousands of outputs; the
    /// check is linear (the pairwise one took 42 s for 400 frames), and still finds a
    /// repeated output and an input among them.
    #[test]
    fn checking_many_outputs_is_linear_and_still_finds_repeats() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.toml");
        std::fs::write(&input, "").unwrap();
        let mut planned: Vec<(&str, PathBuf)> = (0..20_000)
            .map(|k| ("an image", dir.path().join(format!("f{k}.png"))))
            .collect();
        let t = std::time::Instant::now();
        super::check_outputs(&planned, std::slice::from_ref(&input)).unwrap();
        assert!(t.elapsed().as_secs() < 30, "{:?} for 20,000 outputs", t.elapsed());
        planned.push(("stats.json", dir.path().join("sub/../f7.png")));
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let e = super::check_outputs(&planned, std::slice::from_ref(&input))
            .unwrap_err()
            .to_string();
        assert!(e.contains("same file as an image"), "{e}");
        planned.pop();
        planned.push(("probe.csv", input.clone()));
        let e = super::check_outputs(&planned, std::slice::from_ref(&input))
            .unwrap_err()
            .to_string();
        assert!(e.contains("would overwrite the input"), "{e}");
    }
}
