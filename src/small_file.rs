//! Reading the small files glint is given (settings, calibration, sidecar): regular files only
//! and of a bounded size, so that a path to `/dev/zero`, `/dev/urandom`, a FIFO or a huge file
//! is refused at once with one line instead of filling memory or hanging.
//!
//! The file is opened with `O_NONBLOCK`, so that opening a FIFO does not wait for a writer;
//! its type and size are checked on the open descriptor (no race with a rename), and at most
//! one byte more than the cap is read, in case the file grows meanwhile. Streams (dumps,
//! standard input) are not read here: they are read frame by frame into a fixed buffer.

use core::fmt;
use std::fs::{File, FileType, OpenOptions};
use std::io::{self, Read};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

/// The cap for settings and calibration files: far above any real one (a few kB).
pub const MAX_SETTINGS_BYTES: u64 = 1024 * 1024;

/// Why a small file was not read.
#[derive(Debug)]
pub enum SmallFileError {
    /// It could not be opened (missing, no permission).
    Open(io::Error),
    /// It is not a regular file; the kind it is instead.
    NotRegular(&'static str),
    /// It is larger than the cap: `bytes` long, or (`None`) it grew past the cap while being
    /// read.
    TooLarge { bytes: Option<u64>, max_bytes: u64 },
    /// Reading it failed.
    Read(io::Error),
    /// It is not UTF-8 text.
    NotText,
}

impl fmt::Display for SmallFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SmallFileError::Open(e) => write!(f, "{e}"),
            SmallFileError::NotRegular(kind) => write!(f, "{kind}, not a regular file"),
            SmallFileError::TooLarge {
                bytes: Some(bytes),
                max_bytes,
            } => write!(f, "{bytes} bytes is too large (at most {max_bytes} bytes)"),
            SmallFileError::TooLarge {
                bytes: None,
                max_bytes,
            } => write!(
                f,
                "it grew while being read, and is too large (at most {max_bytes} bytes)"
            ),
            SmallFileError::Read(e) => write!(f, "{e}"),
            SmallFileError::NotText => write!(f, "not UTF-8 text"),
        }
    }
}

// The OS's text is part of the message, so it is not also given as a source: an error chain
// printed whole would say it twice.
impl std::error::Error for SmallFileError {}

impl SmallFileError {
    /// Whether the file does not exist (for files that are optional, like a sidecar).
    pub fn is_not_found(&self) -> bool {
        matches!(self, SmallFileError::Open(e) if e.kind() == io::ErrorKind::NotFound)
    }
}

/// The bytes of the regular file at `path`, if it holds at most `max_bytes`.
pub fn read_bytes(path: &Path, max_bytes: u64) -> Result<Vec<u8>, SmallFileError> {
    let file = OpenOptions::new()
        .read(true)
        .custom_flags(nix::fcntl::OFlag::O_NONBLOCK.bits())
        .open(path)
        .map_err(SmallFileError::Open)?;
    let metadata = file.metadata().map_err(SmallFileError::Read)?;
    let kind = metadata.file_type();
    if !kind.is_file() {
        return Err(SmallFileError::NotRegular(describe(kind)));
    }
    if metadata.len() > max_bytes {
        return Err(SmallFileError::TooLarge {
            bytes: Some(metadata.len()),
            max_bytes,
        });
    }
    read_at_most(file, max_bytes)
}

/// The text of the regular file at `path`, if it holds at most `max_bytes`.
pub fn read_text(path: &Path, max_bytes: u64) -> Result<String, SmallFileError> {
    String::from_utf8(read_bytes(path, max_bytes)?).map_err(|_| SmallFileError::NotText)
}

/// Reads at most `max_bytes` (one more tells a file that grew).
fn read_at_most(file: File, max_bytes: u64) -> Result<Vec<u8>, SmallFileError> {
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(SmallFileError::Read)?;
    if bytes.len() as u64 > max_bytes {
        return Err(SmallFileError::TooLarge {
            bytes: None,
            max_bytes,
        });
    }
    Ok(bytes)
}

/// What a file that is not a regular file is.
fn describe(kind: FileType) -> &'static str {
    if kind.is_dir() {
        "a directory"
    } else if kind.is_fifo() {
        "a FIFO"
    } else if kind.is_char_device() {
        "a character device"
    } else if kind.is_block_device() {
        "a block device"
    } else if kind.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_regular_file_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        std::fs::write(&path, "size = \"640x480\"\n").unwrap();
        assert_eq!(read_text(&path, 100).unwrap(), "size = \"640x480\"\n");
        std::fs::write(&path, [0xffu8, 0xfe]).unwrap();
        assert!(matches!(
            read_text(&path, 100),
            Err(SmallFileError::NotText)
        ));
    }

    #[test]
    fn devices_directories_and_large_files_are_refused() {
        for (path, want) in [
            ("/dev/zero", "a character device, not a regular file"),
            ("/dev/urandom", "a character device, not a regular file"),
            ("/", "a directory, not a regular file"),
        ] {
            let e = read_bytes(Path::new(path), MAX_SETTINGS_BYTES).unwrap_err();
            assert_eq!(e.to_string(), want, "{path}");
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        std::fs::write(&path, vec![b'\n'; 101]).unwrap();
        let e = read_bytes(&path, 100).unwrap_err();
        assert_eq!(e.to_string(), "101 bytes is too large (at most 100 bytes)");
        let e = read_bytes(&dir.path().join("missing"), 100).unwrap_err();
        assert!(e.is_not_found(), "{e}");
    }

    #[test]
    fn a_fifo_is_refused_without_waiting_for_a_writer() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fifo");
        nix::unistd::mkfifo(&path, nix::sys::stat::Mode::S_IRWXU).unwrap();
        let e = read_bytes(&path, 100).unwrap_err();
        assert_eq!(e.to_string(), "a FIFO, not a regular file");
    }
}
