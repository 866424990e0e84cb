//! The tolerance budget of smoothed G-code, and its check on the text as written.
//!
//! The two-sided tolerance `tol` holds for the path the controller runs, so everything
//! between the smoothed curve and that path is paid from it:
//!
//! * `chord`: flattening curves G-code cannot carry into G1 lines (and the long-block
//!   emitters' merging, [`crate::write::chain`]);
//! * `rounding`: printing coordinates with `decimals` digits moves a point by up to half
//!   a unit of the last digit per axis, `0.5 10^-d sqrt(3)` mm ([`crate::numbers::rounding_mm`];
//!   an inch program is written in inches, so its rounding is 25.4 times larger);
//! * `blend`: a controller's own blending between blocks when it is told a bound
//!   (LinuxCNC's `G64 P Q` adds up to `P + Q`, [`crate::controller::linuxcnc::Blend`]).
//!
//! The curves are therefore built to `tol - chord - rounding - blend`
//! ([`Budget::curve_tol_mm`]). What is measured in the end is the written text itself:
//! [`read_back`] parses it as a controller would and measures it against the program
//! both ways; the budget holds when that deviation plus the blending is within `tol`
//! ([`Budget::holds`]).

use crate::error::ParseError;
use crate::interpreter::program::{parse_bytes, ParseOptions, Program};
use ncsmooth::verify::{deviation, Deviation};
use ncsmooth::Toolpath;

/// How a tolerance is shared between the curves and what writing them costs (see the
/// module doc). All lengths in mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// The two-sided tolerance of the path the controller runs.
    pub tol_mm: f64,
    /// Flattening chord.
    pub chord_mm: f64,
    /// Largest move of a point by printing it.
    pub rounding_mm: f64,
    /// The controller's blending (`P + Q`), 0 when it blends nothing.
    pub blend_mm: f64,
}

impl Budget {
    /// The budget of `program` written with `decimals` millimetre decimals (inch programs
    /// get one more, in inches), flattened within `chord_mm`, blended by the controller
    /// by up to `blend_mm`.
    ///
    /// ```
    /// use ncsmooth_gcode::{parse_str, Budget, ParseOptions};
    ///
    /// let p = parse_str("G21 G1 X1 F600\n", "a.ngc", &ParseOptions::default()).unwrap();
    /// let b = Budget::new(&p, 0.01, 0.001, 4, 0.001);
    /// // 4 decimals round a point by up to 0.5e-4 sqrt(3) mm.
    /// assert!((b.curve_tol_mm() - (0.01 - 0.001 - 0.5e-4 * 3f64.sqrt() - 0.001)).abs() < 1e-15);
    /// ```
    pub fn new(
        program: &Program,
        tol_mm: f64,
        chord_mm: f64,
        decimals: usize,
        blend_mm: f64,
    ) -> Budget {
        // Inch programs are written in inches: their rounding applies where they are.
        let rounding_mm = program
            .stats
            .units_seen
            .iter()
            .map(|&u| crate::numbers::rounding_mm_for(u, decimals))
            .fold(crate::numbers::rounding_mm(decimals), f64::max);
        Budget {
            tol_mm,
            chord_mm,
            rounding_mm,
            blend_mm,
        }
    }

    /// What the curves may use: `tol - chord - rounding - blend` (may be negative: the
    /// caller refuses such settings).
    pub fn curve_tol_mm(&self) -> f64 {
        self.tol_mm - self.chord_mm - self.rounding_mm - self.blend_mm
    }

    /// Whether the written text's measured deviation `dev`, with the blending on top,
    /// is within the tolerance.
    pub fn holds(&self, dev: &Deviation) -> bool {
        dev.within(self.tol_mm - self.blend_mm)
    }
}

/// The path of the written `text` (named `name` in errors) as the controller will read
/// it. An error means the text does not read back (a writer bug, never the user's).
pub fn read_written(text: &[u8], name: &str) -> Result<Toolpath, ParseError> {
    read_written_with(text, name, &Default::default())
}

/// [`read_written`] with the reader's options (the default units the program was read in).
pub fn read_written_with(
    text: &[u8],
    name: &str,
    opts: &ParseOptions,
) -> Result<Toolpath, ParseError> {
    Ok(parse_bytes(text, name, opts)?.toolpath)
}

/// [`read_written`], measured against `program` both ways to `accuracy_mm`: the path read
/// back and its deviation.
pub fn read_back(
    text: &[u8],
    name: &str,
    program: &Toolpath,
    accuracy_mm: f64,
) -> Result<(Toolpath, Deviation), ParseError> {
    read_back_with(text, name, program, accuracy_mm, &Default::default())
}

/// [`read_back`] with the reader's options.
pub fn read_back_with(
    text: &[u8],
    name: &str,
    program: &Toolpath,
    accuracy_mm: f64,
    opts: &ParseOptions,
) -> Result<(Toolpath, Deviation), ParseError> {
    let written = read_written_with(text, name, opts)?;
    let dev = deviation(&written, program, accuracy_mm);
    Ok((written, dev))
}
