//! Shared by the binary's integration tests: running it, scratch directories, and where
//! the real test data lives (`../shared/data` beside the workspace, or
//! `$NCSMOOTH_SHARED_DATA`; tests that need it skip with a message when it is absent).
#![allow(dead_code)] // each test crate uses a subset

use std::path::PathBuf;
use std::process::{Command, Output};

/// The `ncsmooth` binary built for these tests.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ncsmooth"))
}

/// Runs the binary with `args` and waits for it.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// A fresh, empty scratch directory for the test `name` of this process.
pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ncsmooth-cli-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// What the run wrote on stderr.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The shared data directory, when it holds the real G-code files.
pub fn shared_data() -> Option<PathBuf> {
    let base = std::env::var_os("NCSMOOTH_SHARED_DATA").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
        PathBuf::from,
    );
    base.join("gcode").is_dir().then_some(base)
}
