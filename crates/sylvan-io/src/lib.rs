//! The one way Sylvan reads a file named by a user or by an asset.
//!
//! Every input — scene files, positions CSVs, `.lsys` sources, meshes and their buffers,
//! textures, heightmaps, images given to `compare`, camera paths, bake-cache files — is read
//! through [`read`] or [`read_to_string`], so that no input can hang the program or exhaust its
//! memory:
//!
//! - Only regular files are read. Symlinks are followed and the *target's* type is checked, both
//!   before opening and again on the opened handle, so a FIFO (which would block forever), a
//!   character device such as `/dev/zero` (endless), a socket or a directory is refused with a
//!   typed error instead. On Linux the file is opened non-blocking, so even a FIFO swapped in
//!   between the two checks cannot block the open.
//! - The size limit is enforced *while reading*: at most `limit + 1` bytes are ever read, and the
//!   length the file system reports is used only as an allocation hint capped by the limit.
//!
//! The crate has no dependencies, so every Sylvan crate can use it without a dependency cycle.

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::path::Path;

/// One mebibyte, for writing limits.
pub const MIB: u64 = 1 << 20;

/// Why a file could not be read. Display is the "what" of a one-line message; [`ReadError::fix`]
/// is its fix. Callers prefix the file name: `FILE: what — fix`.
#[derive(Debug)]
pub struct ReadError {
    kind: ErrorKind,
}

/// The kind of a [`ReadError`].
#[derive(Debug)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The path does not exist (or a symlink on it dangles).
    NotFound,
    /// The path is not readable by this user.
    PermissionDenied,
    /// The path is a directory.
    Directory,
    /// The path (after following symlinks) is not a regular file: what it is instead.
    NotRegular(&'static str),
    /// The file holds more bytes than the caller's limit.
    TooLarge {
        /// The limit, bytes.
        limit: u64,
    },
    /// The file is not UTF-8 text ([`read_to_string`] only).
    NotUtf8 {
        /// 1-based line of the first invalid byte.
        line: usize,
        /// 1-based byte column of the first invalid byte.
        col: usize,
    },
    /// Any other I/O failure.
    Io(io::Error),
}

impl ReadError {
    fn new(kind: ErrorKind) -> Self {
        ReadError { kind }
    }

    /// What went wrong.
    pub fn kind(&self) -> &ErrorKind {
        &self.kind
    }

    /// How to fix it, one short phrase.
    pub fn fix(&self) -> &'static str {
        match self.kind {
            ErrorKind::NotFound => {
                "check the path (relative paths resolve against the file naming them)"
            }
            ErrorKind::PermissionDenied => "check the file's permissions",
            ErrorKind::Directory => "name a file inside the folder, not the folder",
            ErrorKind::NotRegular(_) => "name a regular file (pipes and devices are not read)",
            ErrorKind::TooLarge { .. } => "use a smaller file",
            ErrorKind::NotUtf8 { .. } => "save the file as UTF-8 text",
            ErrorKind::Io(_) => "check the file and the disk",
        }
    }
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.kind {
            ErrorKind::NotFound => write!(f, "cannot read: no such file"),
            ErrorKind::PermissionDenied => write!(f, "cannot read: permission denied"),
            ErrorKind::Directory => write!(f, "cannot read: it is a directory"),
            ErrorKind::NotRegular(what) => {
                write!(f, "cannot read: it is {what}, not a regular file")
            }
            ErrorKind::TooLarge { limit } => {
                write!(f, "file is larger than {} (the limit)", size(*limit))
            }
            ErrorKind::NotUtf8 { line, col } => {
                write!(f, "{line}:{col}: not UTF-8 text (invalid byte)")
            }
            ErrorKind::Io(e) => write!(f, "cannot read: {e}"),
        }
    }
}

impl std::error::Error for ReadError {}

impl From<io::Error> for ReadError {
    fn from(e: io::Error) -> Self {
        ReadError::new(match e.kind() {
            io::ErrorKind::NotFound => ErrorKind::NotFound,
            io::ErrorKind::PermissionDenied => ErrorKind::PermissionDenied,
            io::ErrorKind::IsADirectory => ErrorKind::Directory,
            _ => ErrorKind::Io(e),
        })
    }
}

/// A byte count for messages: `512 MiB`, `64 KiB`, `100 bytes`.
pub fn size(bytes: u64) -> String {
    if bytes >= MIB && bytes.is_multiple_of(MIB) {
        format!("{} MiB", bytes / MIB)
    } else if bytes >= 1024 && bytes.is_multiple_of(1024) {
        format!("{} KiB", bytes / 1024)
    } else {
        format!("{bytes} bytes")
    }
}

fn describe(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

fn check_type(t: std::fs::FileType) -> Result<(), ReadError> {
    if t.is_file() {
        Ok(())
    } else if t.is_dir() {
        Err(ReadError::new(ErrorKind::Directory))
    } else {
        Err(ReadError::new(ErrorKind::NotRegular(describe(t))))
    }
}

fn open_regular(path: &Path) -> Result<(File, u64), ReadError> {
    // Follows symlinks: the target's type is what counts.
    check_type(std::fs::metadata(path)?.file_type())?;
    let mut opts = OpenOptions::new();
    opts.read(true);
    #[cfg(all(
        target_os = "linux",
        any(
            target_arch = "x86_64",
            target_arch = "x86",
            target_arch = "aarch64",
            target_arch = "arm",
            target_arch = "riscv64"
        )
    ))]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // O_NONBLOCK on these architectures: a FIFO swapped in after the check above cannot block
        // the open (it is refused by the second check below). No effect on regular files.
        opts.custom_flags(0o4000);
    }
    let file = opts.open(path)?;
    let meta = file.metadata()?;
    check_type(meta.file_type())?;
    Ok((file, meta.len()))
}

/// Reads the whole regular file at `path`, refusing special files and any file holding more
/// than `limit` bytes (checked while reading, whatever length the file system reports).
pub fn read(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    let (file, reported) = open_regular(path)?;
    let mut buf = Vec::new();
    // The reported length is a hint only, capped by the limit.
    buf.try_reserve_exact(reported.min(limit) as usize)
        .map_err(|_| ReadError::new(ErrorKind::TooLarge { limit }))?;
    file.take(limit.saturating_add(1)).read_to_end(&mut buf)?;
    if buf.len() as u64 > limit {
        return Err(ReadError::new(ErrorKind::TooLarge { limit }));
    }
    Ok(buf)
}

/// [`read`], then UTF-8: a file that is not UTF-8 text is refused with the line and column of
/// its first invalid byte.
pub fn read_to_string(path: &Path, limit: u64) -> Result<String, ReadError> {
    let bytes = read(path, limit)?;
    String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = 1 + good.iter().filter(|&&b| b == b'\n').count();
        let col = 1 + good.iter().rev().take_while(|&&b| b != b'\n').count();
        ReadError::new(ErrorKind::NotUtf8 { line, col })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("sylvan-io-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn reads_a_file_within_its_limit_and_refuses_one_past_it() {
        let d = tmp("limit");
        let p = d.join("a.txt");
        std::fs::write(&p, b"hello").unwrap();
        assert_eq!(read(&p, 5).unwrap(), b"hello");
        let e = read(&p, 4).unwrap_err();
        assert!(matches!(e.kind(), ErrorKind::TooLarge { limit: 4 }), "{e}");
        assert!(matches!(
            read(&d.join("none"), 9).unwrap_err().kind(),
            ErrorKind::NotFound
        ));
        assert!(matches!(
            read(&d, 9).unwrap_err().kind(),
            ErrorKind::Directory
        ));
    }

    #[cfg(unix)]
    #[test]
    fn refuses_devices_fifos_and_symlinks_to_them_without_blocking() {
        let d = tmp("special");
        let link = d.join("zero.txt");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let e = read(&link, 1 << 30).unwrap_err();
        assert!(matches!(e.kind(), ErrorKind::NotRegular(_)), "{e}");
        assert!(e.to_string().contains("character device"), "{e}");
        let fifo = d.join("pipe.csv");
        let ok = std::process::Command::new("mkfifo").arg(&fifo).status();
        if ok.is_ok_and(|s| s.success()) {
            let e = read(&fifo, 100).unwrap_err();
            assert!(e.to_string().contains("FIFO"), "{e}");
        }
    }

    #[test]
    fn non_utf8_text_names_line_and_column() {
        let d = tmp("utf8");
        let p = d.join("s.toml");
        std::fs::write(&p, b"a = 1\nb = \xff\n").unwrap();
        let e = read_to_string(&p, 100).unwrap_err();
        assert_eq!(e.to_string(), "2:5: not UTF-8 text (invalid byte)");
        assert_eq!(e.fix(), "save the file as UTF-8 text");
    }
}
