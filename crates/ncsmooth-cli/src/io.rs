//! Input and output conventions shared by every subcommand: `-` means stdin/stdout, output
//! files are written atomically ([`OutputFile`]: a temporary file in the same directory,
//! then a rename), so a failure never leaves a partial file behind.
//!
//! Temporary files are listed in a registry while they exist: SIGINT, SIGTERM, SIGHUP and
//! the other terminating signals remove them before the process exits ([`remove_temp_files_on_signals`]), and a run
//! removes those that a process that no longer exists (killed by SIGKILL, a crash, a power
//! cut) left beside its outputs.

use anyhow::{Context, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// What the name of a temporary output file has between `.<name>` and the writer's pid.
const TEMP_INFIX: &str = ".ncsmooth-tmp-";

/// The temporary files of this process that exist. Created, renamed and removed under its
/// lock, which the signal handler takes and keeps until the process exits: no file is
/// created or moved into place after the handler cleaned up, and none is missed.
static TEMP_FILES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The registry of temporary files, locked (a panic elsewhere does not disable it).
fn temp_files() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMP_FILES.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Exit code of a run ended by a signal: this plus the signal number, as a shell reports
/// a process killed by it (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP).
#[cfg(unix)]
const SIGNAL_EXIT_BASE: i32 = 128;

/// Signals on which a run removes its temporary files and exits: those a user, a shell,
/// a job scheduler or a resource limit sends to end a process (SIGPIPE is ignored by
/// Rust's runtime: a broken pipe is an error of the write, handled where it happens; the
/// signals of a crash, SIGSEGV, SIGBUS, SIGABRT, are left to their default, and the next
/// run removes what a dead process left).
#[cfg(unix)]
const TERMINATION_SIGNALS: [i32; 10] = [
    signal_hook::consts::SIGINT,
    signal_hook::consts::SIGTERM,
    signal_hook::consts::SIGHUP,
    signal_hook::consts::SIGQUIT,
    signal_hook::consts::SIGUSR1,
    signal_hook::consts::SIGUSR2,
    signal_hook::consts::SIGALRM,
    signal_hook::consts::SIGVTALRM,
    signal_hook::consts::SIGXCPU,
    signal_hook::consts::SIGXFSZ,
];

/// True when `signal` was ignored when the process started (`nohup` ignores SIGHUP, a
/// non-interactive shell ignores SIGINT in its background jobs): such a signal is left
/// ignored, as the caller asked. Read from Linux's `/proc/self/status`; elsewhere false.
#[cfg(unix)]
fn ignored_at_start(signal: i32) -> bool {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return false;
    };
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigIgn:"))
        .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        .is_some_and(|mask| (1..=64).contains(&signal) && (mask >> (signal - 1)) & 1 == 1)
}

/// Installs the handling of the terminating signals (those not ignored at start): a
/// thread waits for them, removes every registered temporary file and exits with 128 plus
/// the signal number. Outputs already moved into place stay; none is left half written.
#[cfg(unix)]
pub fn remove_temp_files_on_signals() -> Result<()> {
    let wanted: Vec<i32> = TERMINATION_SIGNALS
        .into_iter()
        .filter(|&s| !ignored_at_start(s))
        .collect();
    let mut signals =
        signal_hook::iterator::Signals::new(&wanted).context("installing the signal handlers")?;
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                // Kept locked until the exit: nothing is created or renamed after this.
                let files = temp_files();
                for f in files.iter() {
                    let _ = std::fs::remove_file(f);
                }
                std::process::exit(SIGNAL_EXIT_BASE + signal);
            }
        })
        .context("starting the signal thread")?;
    Ok(())
}

/// Without Unix signals there is nothing to install.
#[cfg(not(unix))]
pub fn remove_temp_files_on_signals() -> Result<()> {
    Ok(())
}

/// True when process `pid` is known to have ended: Linux lists every process of the pid
/// namespace under `/proc`, a process that ended but was not yet reaped as a zombie (state
/// `Z` or `X` in `/proc/<pid>/stat`, after the parenthesised command name). Without
/// `/proc` nothing is known and false is returned, so that no file of a live process is
/// ever removed.
fn process_gone(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return false;
    }
    let proc_dir = PathBuf::from(format!("/proc/{pid}"));
    if !proc_dir.exists() {
        return true;
    }
    std::fs::read_to_string(proc_dir.join("stat")).is_ok_and(|stat| {
        stat.rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state == "Z" || state == "X")
    })
}

/// Removes the temporary files `.<name>.ncsmooth-tmp-<pid>` in `dir` that a process that
/// no longer exists left behind (a run killed by SIGKILL, a crash). A file of a live
/// process (or of this one), or of a process whose fate cannot be told, is kept; failures
/// are ignored (the file is not ours to insist on).
fn remove_stale_temp_files(dir: &Path, name: &str) {
    let prefix = format!(".{name}{TEMP_INFIX}");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let pid = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .filter(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|p| p.parse::<u32>().ok());
        let Some(pid) = pid else { continue };
        if pid != std::process::id()
            && entry.file_type().is_ok_and(|t| t.is_file())
            && process_gone(pid)
        {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

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

/// An output file being written: a temporary file beside the destination
/// (`.<name>.ncsmooth-tmp-<pid>`), renamed into place by [`OutputFile::commit`] or
/// [`commit_all`] and removed if dropped uncommitted (an error, a panic) or on a signal
/// ([`remove_temp_files_on_signals`]), so a failed or interrupted run never leaves a
/// partial file behind. Opening one removes such files of the same destination that dead
/// processes left.
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
        remove_stale_temp_files(&dir, &name);
        let tmp = dir.join(format!(".{name}{TEMP_INFIX}{}", std::process::id()));
        let mut registry = temp_files();
        let file =
            std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        registry.push(tmp.clone());
        Ok(OutputFile {
            dest,
            tmp: Some(tmp),
            file,
        })
    }

    /// Flushes the data to disk and moves the file into place.
    pub fn commit(self) -> Result<()> {
        commit_all([self])
    }
}

/// Flushes every file to disk, then moves them all into place at once (under the lock of
/// the registry: a signal comes before all of them or after). A failure removes the
/// temporary files not yet moved.
pub fn commit_all(files: impl IntoIterator<Item = OutputFile>) -> Result<()> {
    let mut files: Vec<OutputFile> = files.into_iter().collect();
    for f in &files {
        if f.tmp.is_some() {
            f.file
                .sync_all()
                .with_context(|| format!("writing {}", f.dest.display()))?;
        }
    }
    let mut registry = temp_files();
    let mut done = Ok(());
    for f in &mut files {
        let Some(tmp) = f.tmp.take() else { continue };
        if done.is_ok() {
            done = std::fs::rename(&tmp, &f.dest)
                .with_context(|| format!("renaming onto {}", f.dest.display()));
        }
        if done.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        registry.retain(|p| *p != tmp);
    }
    // Released before the files are dropped (their drop takes the lock).
    drop(registry);
    done
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
            let mut registry = temp_files();
            let _ = std::fs::remove_file(&tmp);
            registry.retain(|p| *p != tmp);
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
/// run. `input` is the input path (`None` for a built-in input; `-`, stdin, is the file
/// it is redirected from, if any);
/// `outputs` pairs each output path with the option that named it. `-` (stdout) and
/// character devices such as `/dev/null` are exempt.
pub fn check_outputs(input: Option<&str>, outputs: &[(&str, &Path)]) -> Result<()> {
    // A missing input is reported as such when it is read. Stdin redirected from a file
    // (`smooth - -o f.ngc < f.ngc`) is that file (Linux's `/dev/stdin` links to it).
    let input = input
        .map(|p| match p {
            "-" => (display_name(p), Path::new(STDIN_PATH)),
            _ => (p, Path::new(p)),
        })
        .filter(|(_, path)| path.exists())
        .and_then(|(name, path)| FileIdentity::of(path).map(|id| (name, id)));
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

/// Where stdin's file can be looked at (a link to the file or pipe it reads from).
const STDIN_PATH: &str = "/dev/stdin";

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
