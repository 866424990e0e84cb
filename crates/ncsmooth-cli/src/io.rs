//! Input and output conventions shared by every subcommand: `-` means stdin/stdout, output
//! files are written atomically ([`OutputFile`]: a temporary file in the same directory,
//! then a rename), so a failure never leaves a partial file behind.

use anyhow::{Context, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// A user error (bad input, bad options): exit code 2.
#[derive(Debug)]
pub struct BadInput(pub String);

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for BadInput {}

/// Reads a whole input file, or stdin for `-`. A missing or unreadable file is bad input.
pub fn read_input(path: &str) -> Result<Vec<u8>> {
    if path == "-" {
        let mut buf = Vec::new();
        std::io::stdin()
            .read_to_end(&mut buf)
            .context("reading standard input")?;
        return Ok(buf);
    }
    std::fs::read(path).map_err(|e| BadInput(format!("cannot read {path}: {e}")).into())
}

/// An output file being written: a temporary file beside the destination, renamed into
/// place by [`OutputFile::commit`] and removed if dropped uncommitted (an error, a panic),
/// so a failed run never leaves a partial file behind.
///
/// A symbolic link is followed (the link stays, its target is replaced). A destination that
/// exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is written in place:
/// renaming over it would replace the device node with a plain file.
pub struct OutputFile {
    dest: PathBuf,
    tmp: Option<PathBuf>,
    file: std::fs::File,
}

impl OutputFile {
    /// Opens `path` for writing. A missing directory or a directory as destination is bad
    /// input (exit 2).
    pub fn create(path: &Path) -> Result<OutputFile> {
        match std::fs::metadata(path) {
            Ok(meta) if meta.is_dir() => {
                return Err(BadInput(format!("output {} is a directory", path.display())).into());
            }
            Ok(meta) if !meta.is_file() => {
                let file = std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .with_context(|| format!("opening {}", path.display()))?;
                return Ok(OutputFile {
                    dest: path.to_path_buf(),
                    tmp: None,
                    file,
                });
            }
            _ => {}
        }
        let dest = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        let dir = match dest.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if !dir.is_dir() {
            return Err(
                BadInput(format!("output directory {} does not exist", dir.display())).into(),
            );
        }
        let name = dest
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = dir.join(format!(".{name}.ncsmooth-tmp-{}", std::process::id()));
        let file =
            std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        Ok(OutputFile {
            dest,
            tmp: Some(tmp),
            file,
        })
    }

    /// Flushes the data to disk and moves the file into place.
    pub fn commit(mut self) -> Result<()> {
        if let Some(tmp) = self.tmp.take() {
            let done = self
                .file
                .sync_all()
                .map_err(anyhow::Error::from)
                .and_then(|()| {
                    std::fs::rename(&tmp, &self.dest)
                        .with_context(|| format!("renaming onto {}", self.dest.display()))
                });
            if done.is_err() {
                let _ = std::fs::remove_file(&tmp);
            }
            done?;
        }
        Ok(())
    }
}

impl Write for OutputFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Writes `bytes` to `path` atomically ([`OutputFile`]), or to stdout for `-`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if path.as_os_str() == "-" {
        return print_stdout(&String::from_utf8_lossy(bytes));
    }
    let mut f = OutputFile::create(path)?;
    f.write_all(bytes)
        .with_context(|| format!("writing {}", path.display()))?;
    f.commit()
}

/// Identity of a file named on the command line, for telling whether two names are the same
/// file: its device and inode when it exists (Unix), and its canonical path (for a name
/// that does not exist yet: the canonical directory joined with the file name).
#[derive(Debug, PartialEq, Eq)]
struct FileIdentity {
    /// `(device, inode)` of an existing file on Unix.
    node: Option<(u64, u64)>,
    /// Canonical path, when it can be resolved.
    path: Option<PathBuf>,
}

impl FileIdentity {
    /// The identity of `path`, or `None` when it is a character device (`/dev/null`, a
    /// terminal): writing one twice, or reading and writing it, destroys nothing.
    fn of(path: &Path) -> Option<FileIdentity> {
        let meta = std::fs::metadata(path).ok();
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if meta
                .as_ref()
                .is_some_and(|m| m.file_type().is_char_device())
            {
                return None;
            }
        }
        #[cfg(unix)]
        let node = {
            use std::os::unix::fs::MetadataExt;
            meta.as_ref().map(|m| (m.dev(), m.ino()))
        };
        #[cfg(not(unix))]
        let node = None;
        let path = match meta {
            Some(_) => std::fs::canonicalize(path).ok(),
            None => {
                let dir = match path.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d,
                    _ => Path::new("."),
                };
                match (std::fs::canonicalize(dir), path.file_name()) {
                    (Ok(dir), Some(name)) => Some(dir.join(name)),
                    _ => None,
                }
            }
        };
        Some(FileIdentity { node, path })
    }

    /// True when both name the same file: the same inode, or the same canonical path.
    fn same_file(&self, other: &FileIdentity) -> bool {
        (self.node.is_some() && self.node == other.node)
            || (self.path.is_some() && self.path == other.path)
    }
}

/// Refuses (bad input, exit 2) a run whose outputs would destroy its input or each other,
/// before anything is written: an output that is the input file (the same path, a
/// symbolic link to it or a hard link of it) or the same file as another output of the
/// run. `input` is the input path (`None` for a built-in input; `-`, stdin, is skipped);
/// `outputs` pairs each output path with the option that named it. `-` (stdout) and
/// character devices such as `/dev/null` are exempt.
pub fn check_outputs(input: Option<&str>, outputs: &[(&str, &Path)]) -> Result<()> {
    // A missing input is reported as such when it is read.
    let input = input
        .filter(|p| *p != "-" && Path::new(p).exists())
        .and_then(|p| FileIdentity::of(Path::new(p)).map(|id| (p, id)));
    let mut seen: Vec<(&str, &Path, FileIdentity)> = Vec::with_capacity(outputs.len());
    for &(flag, path) in outputs {
        if path.as_os_str() == "-" {
            continue;
        }
        let Some(id) = FileIdentity::of(path) else {
            continue;
        };
        if let Some((input, input_id)) = &input {
            if id.same_file(input_id) {
                return Err(BadInput(format!(
                    "{flag} {} is the input file {input}: it would be overwritten; \
                     write to another file",
                    path.display()
                ))
                .into());
            }
        }
        if let Some((other_flag, other, _)) = seen.iter().find(|(_, _, o)| o.same_file(&id)) {
            return Err(BadInput(format!(
                "{flag} {} and {other_flag} {} are the same file: one output would \
                 overwrite the other",
                path.display(),
                other.display()
            ))
            .into());
        }
        seen.push((flag, path, id));
    }
    Ok(())
}

/// Display name of an input path.
pub fn display_name(path: &str) -> &str {
    if path == "-" {
        "<stdin>"
    } else {
        path
    }
}

/// Prints to stdout; a closed pipe (`ncsmooth inspect f | head`) ends the output quietly
/// instead of failing.
pub fn print_stdout(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}
