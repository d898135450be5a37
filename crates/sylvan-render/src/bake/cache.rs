//! The baked-asset cache: one file per (plant, technique, parameters).
//!
//! File layout (little-endian):
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic `SYLVBAKE` |
//! | 4 | container version ([`CONTAINER_VERSION`]) |
//! | 4 | technique format version (the technique's own, bumped when its payload changes) |
//! | 8 + n | technique name (length-prefixed) |
//! | 8 | key: content hash of every input (plant meshes, texture, parameters, versions) |
//! | 8 | payload length |
//! | 8 | payload checksum (FNV-1a 64) |
//! | … | payload |
//!
//! Writes go to a temporary file in the same folder, are flushed to disk, then renamed over the
//! destination, so a reader sees either the old file or the complete new one — an interrupted
//! bake never leaves a half-written cache. A file that is truncated, corrupt, from another
//! version or for other inputs reads as [`Lookup::Stale`] with the reason, and is re-baked.

use super::codec::{Decoder, Encoder, fnv64};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Largest cache file read, bytes (through `sylvan_io`, checked while reading): a FIFO, a
/// device or an oversized file in the cache folder reads as stale, never hangs or fills memory.
pub const MAX_CACHE_FILE_BYTES: u64 = 1 << 30;
/// Hidden temporary files older than this in the cache folder are left from a killed bake and
/// are removed by the next write.
pub const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(3600);

/// Bumped when the container layout above changes.
pub const CONTAINER_VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"SYLVBAKE";

/// What identifies a cache entry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CacheKey {
    /// Technique name (`boxtree`, …).
    pub technique: String,
    /// The technique's payload format version.
    pub format_version: u32,
    /// Content hash of every input.
    pub hash: u64,
}

/// The result of reading a cache file.
#[derive(Debug)]
pub enum Lookup {
    /// The file exists and matches the key: its payload.
    Hit(Vec<u8>),
    /// No file.
    Miss,
    /// A file exists but cannot be used; the reason, for the log.
    Stale(String),
}

/// The folder baked assets go to: `$SYLVAN_CACHE_DIR`, else `$XDG_CACHE_HOME/sylvan`, else
/// `$HOME/.cache/sylvan`, else `.sylvan-cache` in the working directory.
pub fn default_dir() -> PathBuf {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = env("SYLVAN_CACHE_DIR") {
        return d;
    }
    if let Some(d) = env("XDG_CACHE_HOME") {
        return d.join("sylvan");
    }
    if let Some(h) = env("HOME") {
        return h.join(".cache").join("sylvan");
    }
    PathBuf::from(".sylvan-cache")
}

/// The file name for an entry: `<plant>-<technique>-<hash>.sylbake`, the plant name reduced to
/// file-safe characters.
pub fn file_name(plant: &str, key: &CacheKey) -> String {
    let safe: String = plant
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(48)
        .collect();
    format!("{safe}-{}-{:016x}.sylbake", key.technique, key.hash)
}

/// Serialises an entry (header + payload).
pub fn encode(key: &CacheKey, payload: &[u8]) -> Vec<u8> {
    let mut e = Encoder::default();
    e.buf.extend_from_slice(MAGIC);
    e.u32(CONTAINER_VERSION);
    e.u32(key.format_version);
    e.str(&key.technique);
    e.u64(key.hash);
    e.u64(payload.len() as u64);
    e.u64(fnv64(payload));
    e.buf.extend_from_slice(payload);
    e.buf
}

/// Parses an entry and checks it against `key`; the payload on success, else why not.
pub fn decode(bytes: &[u8], key: &CacheKey) -> Result<Vec<u8>, String> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err("not a Sylvan bake file (bad magic)".into());
    }
    let mut d = Decoder::new(&bytes[MAGIC.len()..]);
    let header = (|| {
        Ok::<_, super::codec::DecodeError>((
            d.u32()?,
            d.u32()?,
            d.str()?,
            d.u64()?,
            d.u64()?,
            d.u64()?,
        ))
    })();
    let (container, format, technique, hash, len, checksum) =
        header.map_err(|e| format!("header {e}"))?;
    if container != CONTAINER_VERSION {
        return Err(format!(
            "container version {container}, this build reads {CONTAINER_VERSION}"
        ));
    }
    if technique != key.technique {
        return Err(format!(
            "made for technique '{technique}', not '{}'",
            key.technique
        ));
    }
    if format != key.format_version {
        return Err(format!(
            "{technique} format version {format}, this build reads {}",
            key.format_version
        ));
    }
    if hash != key.hash {
        return Err(format!(
            "inputs changed (key {hash:016x}, now {:016x})",
            key.hash
        ));
    }
    if d.remaining() as u64 != len {
        return Err(format!(
            "truncated or padded: payload is {} bytes, header says {len}",
            d.remaining()
        ));
    }
    let payload = &bytes[bytes.len() - len as usize..];
    if fnv64(payload) != checksum {
        return Err("payload checksum mismatch (corrupt file)".into());
    }
    Ok(payload.to_vec())
}

/// Reads `path` and checks it against `key`.
pub fn read(path: &Path, key: &CacheKey) -> Lookup {
    match sylvan_io::read(path, MAX_CACHE_FILE_BYTES) {
        Ok(bytes) => match decode(&bytes, key) {
            Ok(p) => Lookup::Hit(p),
            Err(why) => Lookup::Stale(why),
        },
        Err(e) if matches!(e.kind(), sylvan_io::ErrorKind::NotFound) => Lookup::Miss,
        Err(e) => Lookup::Stale(e.to_string()),
    }
}

/// Removes hidden `.*.tmp` files in `dir` older than `max_age` (left by a bake killed between
/// creating its temp file and renaming it). Best effort: errors are ignored.
pub fn sweep_stale_temps(dir: &Path, max_age: std::time::Duration) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if !(name.starts_with('.') && name.ends_with(".tmp")) {
            continue;
        }
        let old = e
            .metadata()
            .ok()
            .filter(|m| m.is_file())
            .and_then(|m| m.modified().ok())
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age > max_age);
        if old {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Writes an entry atomically: temp file in the same folder, fsync, rename.
pub fn write(path: &Path, key: &CacheKey, payload: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    sweep_stale_temps(dir, STALE_TEMP_AGE);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "bake".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&encode(key, payload))?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> CacheKey {
        CacheKey {
            technique: "boxtree".into(),
            format_version: 3,
            hash: 0x1234,
        }
    }

    #[cfg(unix)]
    #[test]
    fn fifos_and_devices_in_the_cache_read_as_stale_without_blocking() {
        let dir = std::env::temp_dir().join(format!("sylvan-cache-special-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let zero = dir.join("zero.sylbake");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        assert!(matches!(read(&zero, &key()), Lookup::Stale(w) if w.contains("character device")));
        let fifo = dir.join("fifo.sylbake");
        if std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success())
        {
            assert!(matches!(read(&fifo, &key()), Lookup::Stale(w) if w.contains("FIFO")));
            // A re-bake replaces the FIFO with a regular file.
            write(&fifo, &key(), b"p").unwrap();
            assert!(matches!(read(&fifo, &key()), Lookup::Hit(p) if p == b"p"));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn stale_temp_files_are_swept_fresh_ones_kept() {
        let dir = std::env::temp_dir().join(format!("sylvan-cache-sweep-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let old = dir.join(".a.sylbake.1.tmp");
        std::fs::write(&old, b"x").unwrap();
        let f = std::fs::File::options().write(true).open(&old).unwrap();
        f.set_modified(std::time::SystemTime::now() - 2 * STALE_TEMP_AGE)
            .unwrap();
        drop(f);
        let fresh = dir.join(".b.sylbake.2.tmp");
        std::fs::write(&fresh, b"x").unwrap();
        write(&dir.join("c.sylbake"), &key(), b"p").unwrap();
        assert!(!old.exists() && fresh.exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn hit_miss_stale() {
        let dir = std::env::temp_dir().join(format!("sylvan-cache-test-{}", std::process::id()));
        let path = dir.join(file_name("pine tree", &key()));
        assert!(
            path.to_string_lossy()
                .ends_with("pine_tree-boxtree-0000000000001234.sylbake")
        );
        assert!(matches!(read(&path, &key()), Lookup::Miss));
        write(&path, &key(), b"payload").unwrap();
        assert!(matches!(read(&path, &key()), Lookup::Hit(p) if p == b"payload"));
        let other = CacheKey {
            hash: 0x9999,
            ..key()
        };
        assert!(matches!(read(&path, &other), Lookup::Stale(w) if w.contains("inputs changed")));
        let newer = CacheKey {
            format_version: 4,
            ..key()
        };
        assert!(matches!(read(&path, &newer), Lookup::Stale(w) if w.contains("version")));
        // Every truncation is detected.
        let full = std::fs::read(&path).unwrap();
        for cut in 0..full.len() {
            std::fs::write(&path, &full[..cut]).unwrap();
            assert!(matches!(read(&path, &key()), Lookup::Stale(_)), "cut {cut}");
        }
        // A flipped payload byte is detected.
        let mut bad = full.clone();
        *bad.last_mut().unwrap() ^= 1;
        std::fs::write(&path, &bad).unwrap();
        assert!(matches!(read(&path, &key()), Lookup::Stale(w) if w.contains("checksum")));
        // No temp files left behind.
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
