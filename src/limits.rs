//! Resource bounds, checked before work starts: how much memory a run may plan for, how
//! large an input file may be, and the estimates that are compared against them. A run
//! that would not fit is refused with the estimate, the limit and the input that asked
//! for it, instead of aborting half-way (an allocation failure aborts a Rust process).

use std::io::Read as _;
use std::path::Path;

use crate::error::{Error, Result};

/// Bytes planned per triangle while loading: the triangle (48 B), its corner uvs (24 B),
/// BVH2 nodes (about 2 × 32 B), obvhs' build arrays (about 160 B), the copies made while
/// reordering and tessellating, and the CWBVH (about 12 B, and 100 B for the
/// single-triangle BVH2 it is converted from, while it is built).
/// The largest emitted radiance accepted (MTL `Ke`, glTF emission, `[sky]` radiance and
/// envmap texels times `scale`): irradiance is radiance times up to π, summed over
/// samples and bounces in f32, so values near f32's maximum (3.4e38) would come out as
/// inf. 1e30 leaves eight orders of magnitude for those sums.
pub const MAX_RADIANCE: f32 = 1e30;

pub const BYTES_PER_TRIANGLE: u64 = 448;
/// Bytes per candidate sample of the hierarchy build (position, normal, triangle, the
/// crevice memo and the dart-throwing grid).
pub const BYTES_PER_CANDIDATE: u64 = 48;
/// Bytes per hierarchy node, hierarchy and transport together: the node (32 B), its kd
/// split, clip record, parents and children (CSR), and per-node transport state
/// (direct, gathered, un-shot, accumulated irradiance; integrals' records).
pub const BYTES_PER_NODE: u64 = 320;
/// Bytes per image pixel: direct, indirect and total in float RGB, the PNG and EXR
/// encoders' buffers.
pub const BYTES_PER_PIXEL: u64 = 64;

/// Largest scene (TOML) or points file read.
pub const MAX_TEXT_BYTES: u64 = 256 << 20;
/// Largest mesh (OBJ), material (MTL) or texture file read.
pub const MAX_MESH_BYTES: u64 = 8 << 30;

/// Limits of one run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Memory a run may plan for, in bytes (`--max-memory`, `MESHRAD_MAX_MEMORY`;
    /// default: half of the machine's memory).
    pub max_memory: u64,
}

impl Default for Limits {
    /// `MESHRAD_MAX_MEMORY` if set and valid, else half of the machine's memory.
    fn default() -> Self {
        let from_env = std::env::var("MESHRAD_MAX_MEMORY")
            .ok()
            .and_then(|s| parse_bytes(&s).ok());
        Limits {
            max_memory: from_env.unwrap_or_else(default_max_memory),
        }
    }
}

/// This process's peak resident memory in bytes (`VmHWM` of `/proc/self/status`), where
/// the system reports it.
pub fn peak_resident() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib << 10)
}

/// Half of `MemTotal` from `/proc/meminfo`; 4 GiB where that cannot be read.
pub fn default_max_memory() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("MemTotal:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|k| k.parse::<u64>().ok())
        })
        .map(|kib| kib * 1024 / 2)
        .unwrap_or(4 << 30)
}

/// Parses a byte count: a number with an optional suffix K, M, G, T (powers of 1024,
/// optionally followed by `B` or `iB`), e.g. `512M`, `8GiB`, `1.5G`, `1000000`.
pub fn parse_bytes(s: &str) -> std::result::Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let v: f64 = num
        .parse()
        .map_err(|_| format!("`{s}` is not a byte count (e.g. 512M, 8G)"))?;
    let mult = match unit
        .trim()
        .to_ascii_uppercase()
        .trim_end_matches("IB")
        .trim_end_matches('B')
    {
        "" => 1u64,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        "T" => 1 << 40,
        _ => return Err(format!("`{s}`: unknown unit `{unit}` (use K, M, G or T)")),
    };
    let bytes = v * mult as f64;
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(format!("`{s}` is not a usable byte count"));
    }
    Ok(bytes as u64)
}

/// A byte count as people read it (`1.5 GiB`).
pub fn human(bytes: f64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{v:.0} B")
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// A planned allocation: what it is for and its size in bytes (f64: estimates of absurd
/// inputs must not overflow).
#[derive(Clone, Debug)]
pub struct Part {
    pub what: String,
    pub bytes: f64,
}

impl Limits {
    /// Refuses `parts` when together they exceed the limit; `input` names the file and
    /// `key` the setting the error blames.
    pub fn check(&self, input: &Path, key: &str, parts: &[Part]) -> Result<()> {
        let total: f64 = parts.iter().map(|p| p.bytes).sum();
        if total <= self.max_memory as f64 {
            return Ok(());
        }
        let detail = parts
            .iter()
            .filter(|p| p.bytes > 0.0)
            .map(|p| format!("{} {}", p.what, human(p.bytes)))
            .collect::<Vec<_>>()
            .join(", ");
        Err(Error::Resource {
            path: input.into(),
            key: key.into(),
            message: format!(
                "needs an estimated {} ({detail}), over the limit of {} (--max-memory or \
                 MESHRAD_MAX_MEMORY; default half of the machine's memory)",
                human(total),
                human(self.max_memory as f64)
            ),
        })
    }
}

/// Opens a named pipe without waiting for a writer (a plain `open` blocks until one
/// comes, forever if none does), then makes its reads blocking again: a writer that has
/// not written yet is waited for, and with none the read ends at once, empty.
#[cfg(unix)]
fn open_pipe(path: &Path) -> Result<std::fs::File> {
    use std::os::fd::AsRawFd;
    use std::os::unix::fs::OpenOptionsExt;
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    // SAFETY: fcntl on a descriptor this function owns, with integer arguments only.
    let ok = unsafe {
        let fl = libc::fcntl(f.as_raw_fd(), libc::F_GETFL);
        fl >= 0 && libc::fcntl(f.as_raw_fd(), libc::F_SETFL, fl & !libc::O_NONBLOCK) >= 0
    };
    if !ok {
        return Err(Error::io(path, std::io::Error::last_os_error()));
    }
    Ok(f)
}

#[cfg(not(unix))]
fn open_pipe(path: &Path) -> Result<std::fs::File> {
    std::fs::File::open(path).map_err(|e| Error::io(path, e))
}

/// Reads a whole input file, at most `limit` bytes. Directories, devices and sockets are
/// refused (reading `/dev/zero` would never end); a pipe is read up to the limit.
pub fn read_file(path: &Path, limit: u64) -> Result<Vec<u8>> {
    if path.as_os_str().is_empty() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "empty file name"),
        ));
    }
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let kind = meta.file_type();
    if kind.is_dir() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "is a directory, not a file"),
        ));
    }
    #[cfg(unix)]
    let is_pipe = std::os::unix::fs::FileTypeExt::is_fifo(&kind);
    #[cfg(not(unix))]
    let is_pipe = false;
    if !kind.is_file() && !is_pipe {
        return Err(Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "is not a regular file (a device or socket)",
            ),
        ));
    }
    let too_big = |n: u64| {
        Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "is {} or more, over the {} an input file may have",
                    human(n as f64),
                    human(limit as f64)
                ),
            ),
        )
    };
    if meta.len() > limit {
        return Err(too_big(meta.len()));
    }
    let f = if is_pipe {
        open_pipe(path)?
    } else {
        std::fs::File::open(path).map_err(|e| Error::io(path, e))?
    };
    let mut buf = Vec::with_capacity(meta.len() as usize);
    f.take(limit + 1)
        .read_to_end(&mut buf)
        .map_err(|e| Error::io(path, e))?;
    if buf.len() as u64 > limit {
        return Err(too_big(buf.len() as u64));
    }
    if is_pipe && buf.is_empty() {
        return Err(Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "is a pipe that gave nothing to read (no program writes to it)",
            ),
        ));
    }
    Ok(buf)
}

/// [`read_file`] as UTF-8 text; a leading byte-order mark is dropped.
pub fn read_text(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_file(path, limit)?;
    String::from_utf8(bytes)
        .map(|s| strip_bom(&s).to_string())
        .map_err(|e| {
            Error::io(
                path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, format!("is not UTF-8 text ({e})")),
            )
        })
}

/// `text` without a leading UTF-8 byte-order mark.
pub fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts() {
        assert_eq!(parse_bytes("512M").unwrap(), 512 << 20);
        assert_eq!(parse_bytes("8GiB").unwrap(), 8 << 30);
        assert_eq!(parse_bytes("1.5G").unwrap(), 3 << 29);
        assert_eq!(parse_bytes("1000").unwrap(), 1000);
        assert!(parse_bytes("lots").is_err());
        assert!(parse_bytes("5X").is_err());
        assert!(parse_bytes("0").is_err());
        assert_eq!(human(1536.0), "1.5 KiB");
    }

    #[test]
    fn devices_and_directories_are_refused() {
        assert!(read_file(Path::new("/dev/zero"), 1 << 20).is_err());
        assert!(read_file(Path::new("/"), 1 << 20).is_err());
        assert!(read_file(Path::new(""), 1 << 20).is_err());
    }
}
