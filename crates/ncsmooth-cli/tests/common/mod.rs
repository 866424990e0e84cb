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

/// 64-bit FNV-1a, the hash of the pinned outputs (`tests/golden/outputs.txt`).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The G-code without its trailing `; ` header lines.
pub fn without_header(text: &[u8]) -> &[u8] {
    let mut end = text.len();
    loop {
        let body = &text[..end];
        let body = body.strip_suffix(b"\n").unwrap_or(body);
        let body = body.strip_suffix(b"\r").unwrap_or(body);
        let start = body.iter().rposition(|&c| c == b'\n').map_or(0, |i| i + 1);
        if end == 0 || !body[start..].starts_with(b"; ") {
            return &text[..end];
        }
        end = start;
    }
}
