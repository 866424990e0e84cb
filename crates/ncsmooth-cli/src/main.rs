//! `ncsmooth`: CNC toolpath smoothing, feed planning and interpolation from the command line.
//!
//! Every subcommand takes an input file or `-` for stdin, writes its outputs atomically,
//! and exits with 0 on success, 2 on bad input (a parse error is printed as a rustc-style
//! snippet naming file, line and column) and 1 on an internal error; SIGINT, SIGTERM,
//! SIGHUP and the other terminating signals remove the temporary files and exit with 128
//! plus the signal number. Lengths are
//! in mm, speeds in mm/s, accelerations in mm/s^2, jerks in mm/s^3, times in s.
#![forbid(unsafe_code)]
// Terminal output goes through `diag::say` and `io::print_stdout`, which never panic.
#![deny(clippy::print_stderr, clippy::print_stdout)]

mod cmd_compare;
mod cmd_inspect;
mod cmd_plan;
mod cmd_smooth;
mod demo;
mod diag;
mod io;
mod progress;
mod table_arg;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// CNC toolpath smoothing, feed planning and interpolation.
///
/// Run without arguments for the demo on the built-in butterfly profile.
#[derive(Parser, Debug)]
#[command(name = "ncsmooth", version, about, long_about = None)]
struct Cli {
    /// Print nothing but errors.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Units of a program until its first G20/G21: LinuxCNC reads such a program in the
    /// machine's units ([TRAJ] LINEAR_UNITS), so give the machine's here [default: mm].
    #[arg(long, global = true, value_enum)]
    units: Option<UnitsArg>,
    /// Most threads the work uses (1: one core; outputs are the same for any number)
    /// [default: the machine's cores, at most 4].
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    #[command(subcommand)]
    cmd: Option<Cmd>,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Describe a G-code program: units, planes, moves by kind, lengths (mm), segment-length
    /// percentiles (mm), corner angles (deg), bounding box (mm), warnings.
    Inspect(cmd_inspect::InspectArgs),
    /// Smooth a program within a two-sided tolerance and write G-code.
    Smooth(cmd_smooth::SmoothArgs),
    /// Plan the feed under per-axis limits and write setpoints at a fixed period (CSV:
    /// t s, x y z mm, feed mm/s), with a JSON report measured on the written rows.
    Plan(cmd_plan::PlanArgs),
    /// Run every method on one program under the same limits: a table, `compare.json` and
    /// an HTML page with plots (`index.html`) in `--out`.
    Compare(cmd_compare::CompareArgs),
    /// Run the demo on the built-in butterfly profile and write its report (the default).
    Demo(demo::DemoArgs),
}

/// `--units`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum UnitsArg {
    /// Millimetres (G21).
    Mm,
    /// Inches (G20).
    Inch,
}

/// The reader's settings from the command line (`--units`), set once in `main`.
static PARSE_OPTIONS: std::sync::OnceLock<ncsmooth_gcode::ParseOptions> =
    std::sync::OnceLock::new();

/// The reader's settings every command reads (and reads back) programs with.
pub fn parse_options() -> &'static ncsmooth_gcode::ParseOptions {
    PARSE_OPTIONS.get_or_init(ncsmooth_gcode::ParseOptions::default)
}

/// The warning of a program that moves before any G20/G21 (first at `line`).
pub fn units_warning(name: &str, line: u32) -> String {
    let (units, other) = match parse_options().default_units {
        ncsmooth::Units::Millimetres => ("millimetres", "inch"),
        ncsmooth::Units::Inches => ("inches", "mm"),
    };
    format!(
        "warning: {name}: no G20/G21 before the first move (line {line}): read in {units}; \
         LinuxCNC reads such a program in the machine's units ([TRAJ] LINEAR_UNITS): \
         give --units {other} for a machine in {other}"
    )
}

/// Output verbosity shared by the subcommands.
#[derive(Clone, Copy, Debug)]
pub struct Ui {
    /// Suppress progress bars and summaries.
    pub quiet: bool,
}

impl Ui {
    /// Prints a status line to stderr unless quiet.
    pub fn status(&self, msg: impl AsRef<str>) {
        if !self.quiet {
            diag::say(msg.as_ref());
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    let ui = Ui { quiet: cli.quiet };
    match cli.cmd {
        Some(Cmd::Inspect(a)) => cmd_inspect::run(a, ui),
        Some(Cmd::Smooth(a)) => cmd_smooth::run(a, ui),
        Some(Cmd::Plan(a)) => cmd_plan::run(a, ui),
        Some(Cmd::Compare(a)) => cmd_compare::run(a, ui),
        Some(Cmd::Demo(a)) => demo::run(a, ui),
        None => demo::run(demo::DemoArgs::default(), ui),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let units = match cli.units {
        Some(UnitsArg::Inch) => ncsmooth::Units::Inches,
        _ => ncsmooth::Units::Millimetres,
    };
    ncsmooth::set_threads(cli.threads.unwrap_or(0));
    let _ = PARSE_OPTIONS.set(ncsmooth_gcode::ParseOptions::default().with_default_units(units));
    if let Err(e) = io::remove_temp_files_on_signals() {
        // The run can go on; an interruption may then leave a temporary file, which the
        // next run beside the same output removes.
        diag::say(format_args!("warning: {e:#}"));
    }
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if e.downcast_ref::<io::BadInput>().is_some()
                || e.downcast_ref::<ncsmooth_gcode::ParseError>().is_some()
            {
                // Parse errors were already rendered with their snippet.
                if e.downcast_ref::<ncsmooth_gcode::ParseError>().is_none() {
                    diag::say(format_args!("error: {e:#}"));
                }
                ExitCode::from(2)
            } else {
                diag::say(format_args!("internal error: {e:#}"));
                ExitCode::from(1)
            }
        }
    }
}

/// A parsed input with its source text (for writers that keep the program's own lines).
pub struct Loaded {
    /// The program.
    pub program: ncsmooth_gcode::Program,
    /// Its bytes as read.
    pub src: Vec<u8>,
}

/// Reads and parses an input; parse errors are rendered to stderr and returned.
pub fn load(path: &str) -> Result<Loaded> {
    let src = io::read_input(path)?;
    let name = io::display_name(path);
    match ncsmooth_gcode::parse_bytes(&src, name, parse_options()) {
        Ok(program) => Ok(Loaded { program, src }),
        Err(err) => {
            diag::report_parse_error(&err, &src);
            Err(err.into())
        }
    }
}
