//! Canned cycles (G73, G81-G89).

use super::Interp;
use crate::error::{ParseError, ParseErrorKind};

impl Interp<'_> {
    /// Runs canned cycle `code10` for this block.
    pub(crate) fn cycle(&mut self, code10: u16) -> Result<(), ParseError> {
        Err(self.err_line(ParseErrorKind::Unsupported {
            word: super::block::code_name('G', u32::from(code10)),
            why: "canned cycles are not supported yet",
        }))
    }
}
