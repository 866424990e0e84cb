//! Shared by the integration tests: where the real test data lives and how to load it.
//!
//! The data (GPL/MIT real G-code files and the benchmark profiles) is not part of the
//! repository: it is read from `../shared/data` beside the workspace, as CI has it, or from
//! `$NCSMOOTH_SHARED_DATA` when that is set (a git worktree elsewhere). When it is absent
//! every test that needs it prints a SKIP message and passes, so a fresh clone is green.
#![allow(dead_code)] // each test crate uses a subset

use ncsmooth::Toolpath;
use std::path::{Path, PathBuf};

/// `REL` under the shared data directory, if it exists; otherwise prints a SKIP message.
pub fn data_path(rel: &str) -> Option<PathBuf> {
    let beside = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"));
    let base = match std::env::var_os("NCSMOOTH_SHARED_DATA") {
        Some(d) => PathBuf::from(d),
        None => beside,
    };
    let p = base.join(rel);
    if p.exists() {
        Some(p)
    } else {
        println!("SKIP: test data {} not found", p.display());
        None
    }
}

/// Parses a G-code file; a parse error fails the test with its location.
pub fn parse_file(p: &Path) -> Toolpath {
    let bytes = std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    ncsmooth_gcode::parse_bytes(&bytes, &p.display().to_string(), &Default::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .toolpath
}

/// [`data_path`] then [`parse_file`].
pub fn load(rel: &str) -> Option<Toolpath> {
    data_path(rel).map(|p| parse_file(&p))
}
