//! Input and output conventions shared by every subcommand: `-` means stdin/stdout, output
//! files are written atomically (a temporary file in the same directory, then a rename), so
//! a failure never leaves a partial file behind.

use anyhow::{Context, Result};
use std::io::{Read, Write};
use std::path::Path;

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

/// Writes `bytes` to `path` atomically, or to stdout for `-`.
///
/// A regular file (or a new one) is written to a temporary file beside it and renamed into
/// place; a symbolic link is followed, so the link stays and its target is replaced. A path
/// that exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is written in
/// place: renaming over it would replace the device node with a plain file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if path.as_os_str() == "-" {
        return print_stdout(&String::from_utf8_lossy(bytes));
    }
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() && !meta.is_dir() => {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .with_context(|| format!("opening {}", path.display()))?;
            f.write_all(bytes)
                .with_context(|| format!("writing {}", path.display()))?;
            return Ok(());
        }
        Ok(meta) if meta.is_dir() => {
            return Err(BadInput(format!("output {} is a directory", path.display())).into());
        }
        _ => {}
    }
    let resolved = std::fs::canonicalize(path).ok();
    let path = resolved.as_deref().unwrap_or(path);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(BadInput(format!("output directory {} does not exist", dir.display())).into());
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.ncsmooth-tmp-{}", std::process::id()));
    let result = (|| -> Result<()> {
        let mut f =
            std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path).with_context(|| format!("renaming onto {}", path.display()))?;
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
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
