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
        return print_stdout(bytes);
    }
    let mut f = OutputFile::create(path)?;
    f.write_all(bytes)
        .with_context(|| format!("writing {}", path.display()))?;
    f.commit()
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
pub fn print_stdout(text: &[u8]) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}
