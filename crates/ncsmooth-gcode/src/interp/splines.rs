//! Splines: G5 (cubic), G5.1 (quadratic), G5.2/G5.3 (NURBS).

use super::Interp;
use crate::error::{ParseError, ParseErrorKind};

impl Interp<'_> {
    /// Runs spline motion `code10` for this block.
    pub(crate) fn spline(&mut self, code10: u16, _prev: u16) -> Result<(), ParseError> {
        Err(self.err_line(ParseErrorKind::Unsupported {
            word: super::block::code_name('G', u32::from(code10)),
            why: "splines are not supported yet",
        }))
    }
}
