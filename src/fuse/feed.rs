//! Recorded report lines from files, handed to the fuser in capture-time order.
//!
//! Each file is one camera's JSON lines (what `glint run` or `glint track` wrote). The feed
//! keeps each file's next good report and hands over the earliest, so files are read as
//! streams, never whole. A bad line (cut short, garbage, not UTF-8, longer than a report) is
//! reported with its file and line number and skipped; it never stops the others.

use core::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};

use super::line::{self, LineError, Report, MAX_LINE_BYTES};

/// Why the feed cannot go on.
#[derive(Debug)]
pub enum FeedError {
    /// A file could not be opened.
    Open { path: PathBuf, source: io::Error },
    /// Reading a file failed.
    Read { path: PathBuf, source: io::Error },
    /// A device or a directory, not a file of report lines.
    NotLines(PathBuf),
}

impl fmt::Display for FeedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FeedError::Open { path, source } => {
                write!(f, "cannot open {}: {source}", path.display())
            }
            FeedError::Read { path, source } => {
                write!(f, "cannot read {}: {source}", path.display())
            }
            FeedError::NotLines(path) => write!(
                f,
                "{} is a device or a directory, not a file of report lines",
                path.display()
            ),
        }
    }
}

impl std::error::Error for FeedError {}

/// A line that was skipped.
#[derive(Debug)]
pub struct BadLine<'a> {
    /// The camera (file) index.
    pub camera: usize,
    /// Its file.
    pub path: &'a Path,
    /// 1-based line number.
    pub line: u64,
    /// Why.
    pub error: LineError,
}

struct Source {
    path: PathBuf,
    reader: Box<dyn BufRead>,
    line: u64,
    /// The next good report and its line number; `None` at the end.
    head: Option<(u64, Report)>,
    done: bool,
}

/// Several files of report lines, merged by capture time.
pub struct FileFeed {
    sources: Vec<Source>,
    buffer: Vec<u8>,
}

impl FileFeed {
    /// Opens every file (camera `k` is `paths[k]`).
    pub fn open(paths: &[PathBuf]) -> Result<FileFeed, FeedError> {
        let sources = paths
            .iter()
            .map(|path| {
                let file = File::open(path).map_err(|source| FeedError::Open {
                    path: path.clone(),
                    source,
                })?;
                // A device never ends (/dev/zero would be read for ever); a FIFO is a stream
                // of lines like a file and is taken.
                let kind = file.metadata().map(|m| m.file_type());
                if kind.is_ok_and(|k| k.is_char_device() || k.is_block_device() || k.is_dir()) {
                    return Err(FeedError::NotLines(path.clone()));
                }
                Ok(Source {
                    path: path.clone(),
                    reader: Box::new(BufReader::new(file)),
                    line: 0,
                    head: None,
                    done: false,
                })
            })
            .collect::<Result<_, FeedError>>()?;
        Ok(FileFeed::from_sources(sources))
    }

    /// A feed over readers already open (named by `paths` in messages).
    pub fn from_readers(readers: Vec<(PathBuf, Box<dyn BufRead>)>) -> FileFeed {
        FileFeed::from_sources(
            readers
                .into_iter()
                .map(|(path, reader)| Source {
                    path,
                    reader,
                    line: 0,
                    head: None,
                    done: false,
                })
                .collect(),
        )
    }

    fn from_sources(sources: Vec<Source>) -> FileFeed {
        FileFeed {
            sources,
            buffer: Vec::with_capacity(4096),
        }
    }

    /// The next report of any camera in capture-time order (ties: the lower camera first),
    /// with its camera and line number; bad lines go to `on_bad` on the way.
    pub fn next(
        &mut self,
        on_bad: &mut dyn FnMut(BadLine<'_>),
    ) -> Result<Option<(usize, u64, Report)>, FeedError> {
        for camera in 0..self.sources.len() {
            self.fill(camera, on_bad)?;
        }
        let earliest = self
            .sources
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.head.as_ref().map(|(_, r)| (r.t_us, k)))
            .min();
        let Some((_, camera)) = earliest else {
            return Ok(None);
        };
        let head = self.sources.get_mut(camera).and_then(|s| s.head.take());
        Ok(head.map(|(line, report)| (camera, line, report)))
    }

    /// Reads camera `camera`'s next good report into its head, if it has none.
    fn fill(
        &mut self,
        camera: usize,
        on_bad: &mut dyn FnMut(BadLine<'_>),
    ) -> Result<(), FeedError> {
        let Some(source) = self.sources.get_mut(camera) else {
            return Ok(());
        };
        while source.head.is_none() && !source.done {
            let read = read_bounded_line(&mut source.reader, &mut self.buffer).map_err(|e| {
                FeedError::Read {
                    path: source.path.clone(),
                    source: e,
                }
            })?;
            let Some(complete) = read else {
                source.done = true;
                break;
            };
            source.line += 1;
            let parsed = if !complete {
                Err(LineError::TooLong(self.buffer.len()))
            } else {
                match std::str::from_utf8(&self.buffer) {
                    Ok(text) if text.trim().is_empty() => continue,
                    Ok(text) => line::parse(text, None),
                    Err(_) => Err(LineError::NotJson("not UTF-8 text".to_owned())),
                }
            };
            match parsed {
                Ok(report) => source.head = Some((source.line, report)),
                Err(error) => on_bad(BadLine {
                    camera,
                    path: &source.path,
                    line: source.line,
                    error,
                }),
            }
        }
        Ok(())
    }
}

/// Reads one line into `buffer` (without its line feed), keeping at most [`MAX_LINE_BYTES`]:
/// `Some(true)` for a whole line, `Some(false)` for one too long (the rest is skipped, up to
/// its line feed), `None` at the end of the input.
fn read_bounded_line(reader: &mut dyn BufRead, buffer: &mut Vec<u8>) -> io::Result<Option<bool>> {
    buffer.clear();
    let mut any = false;
    let mut whole = true;
    loop {
        let available = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if available.is_empty() {
            return Ok(any.then_some(whole));
        }
        any = true;
        let (chunk, used, ends) = match available.iter().position(|&b| b == b'\n') {
            Some(i) => (&available[..i], i + 1, true),
            None => (available, available.len(), false),
        };
        let room = (MAX_LINE_BYTES + 1).saturating_sub(buffer.len());
        if chunk.len() > room {
            whole = false;
        }
        buffer.extend_from_slice(&chunk[..chunk.len().min(room)]);
        if buffer.len() > MAX_LINE_BYTES {
            whole = false;
        }
        reader.consume(used);
        if ends {
            if buffer.last() == Some(&b'\r') {
                buffer.pop();
            }
            return Ok(Some(whole));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(files: &[&str]) -> FileFeed {
        FileFeed::from_readers(
            files
                .iter()
                .enumerate()
                .map(|(k, text)| {
                    let reader: Box<dyn BufRead> =
                        Box::new(io::Cursor::new(text.as_bytes().to_vec()));
                    (PathBuf::from(format!("cam{k}.jsonl")), reader)
                })
                .collect(),
        )
    }

    #[test]
    fn files_are_merged_by_capture_time_and_bad_lines_named() {
        let a = "{\"t\":0.0,\"found\":false}\n{\"t\":0.2,\"found\":false}\n{\"t\":0.4,\"fou";
        let b = "{\"t\":0.1,\"found\":false}\ngarbage\n\n{\"t\":0.3,\"found\":false}\n";
        let mut f = feed(&[a, b]);
        let mut bad = Vec::new();
        let mut order = Vec::new();
        while let Some((camera, line, report)) = f
            .next(&mut |b| bad.push((b.camera, b.line, b.error.to_string())))
            .unwrap()
        {
            order.push((camera, line, report.t_us));
        }
        assert_eq!(
            order,
            [(0, 1, 0), (1, 1, 100_000), (0, 2, 200_000), (1, 4, 300_000)]
        );
        assert_eq!(bad.len(), 2, "{bad:?}");
        assert_eq!((bad[0].0, bad[0].1), (1, 2));
        assert_eq!((bad[1].0, bad[1].1), (0, 3));
        assert!(bad[1].2.contains("cut short"), "{bad:?}");
    }

    #[test]
    fn a_line_longer_than_a_report_is_skipped_not_held() {
        let long = format!(
            "{{\"t\":0.0,\"pad\":\"{}\"}}\n{{\"t\":1.0,\"found\":false}}\n",
            "x".repeat(3 * MAX_LINE_BYTES)
        );
        let mut f = feed(&[&long]);
        let mut bad = Vec::new();
        let (_, line, report) = f.next(&mut |b| bad.push(b.error)).unwrap().unwrap();
        assert_eq!((line, report.t_us), (2, 1_000_000));
        assert!(matches!(bad[..], [LineError::TooLong(_)]));
    }
}
