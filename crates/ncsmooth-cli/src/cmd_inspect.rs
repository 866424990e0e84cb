//! `ncsmooth inspect`: what a program contains ([`InspectReport`]).

use crate::{io, load, Ui};
use anyhow::Result;
use clap::Args;
use ncsmooth_gcode::InspectReport;
use std::path::Path;

/// Arguments of `inspect`.
#[derive(Args, Debug)]
pub struct InspectArgs {
    /// G-code file, or `-` for stdin.
    pub file: String,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Runs `inspect`: a file is read block by block, in memory that does not grow with it;
/// stdin is read whole.
pub fn run(a: InspectArgs, _ui: Ui) -> Result<()> {
    let name = io::display_name(&a.file);
    let r = if a.file == "-" {
        InspectReport::of(name, &load(&a.file)?.program)
    } else {
        let path = Path::new(&a.file);
        InspectReport::read(path, name, crate::parse_options())
            .map_err(|e| crate::diag::reported_at_line(e, path))?
    };
    if a.json {
        io::print_stdout((serde_json::to_string_pretty(&r)? + "\n").as_bytes())
    } else {
        io::print_stdout(r.text().as_bytes())
    }
}
