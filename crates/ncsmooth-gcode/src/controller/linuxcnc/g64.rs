//! The `G64` text LinuxCNC is given: the blend words of a replaced run and the program's
//! own path mode restored after it.

use super::Blend;
use crate::numbers::{decimals_for, push_fixed, unit_mm, MAX_DECIMALS};
use crate::source::PathMode;
use ncsmooth::path::Units;

/// Significant digits `G64 P Q` keep at least, beyond the coordinates' decimals: rounded
/// down to the coordinates' 5 inch decimals, the default `P` of 0.001 mm (3.94e-5 in)
/// printed as `P0.00003`, a quarter of the blending given away.
const BLEND_SIGNIFICANT_DIGITS: i32 = 3;

/// Decimals that print `v` (program units, positive) with [`BLEND_SIGNIFICANT_DIGITS`]
/// significant digits, at least `decimals` and at most [`MAX_DECIMALS`].
fn blend_decimals(v: f64, decimals: usize) -> usize {
    if !(v > 0.0 && v.is_finite()) {
        return decimals;
    }
    let first_digit = (-v.log10()).ceil().max(0.0) as i32;
    let want = (first_digit + BLEND_SIGNIFICANT_DIGITS - 1).max(0) as usize;
    want.clamp(decimals, MAX_DECIMALS.max(decimals))
}

/// `G64 P Q` (or `G61` when `P` would print as 0, which LinuxCNC reads as no bound) for
/// `P = p_mm`, `Q = q_mm` in a program whose unit is `scale` mm, each value rounded down to at least `decimals` and
/// [`BLEND_SIGNIFICANT_DIGITS`] significant digits, so the bound written never exceeds
/// the one asked for.
pub(crate) fn blend_words(p_mm: f64, q_mm: f64, scale: f64, decimals: usize) -> String {
    let decimals = blend_decimals(p_mm / scale, decimals);
    let p10 = 10f64.powi(decimals as i32);
    let down = |v: f64| (v / scale * p10).floor() / p10;
    let (p, q) = (down(p_mm), down(q_mm));
    if p.is_nan() || p <= 0.0 {
        return "G61".to_string();
    }
    let mut t = String::from("G64 P");
    push_fixed(&mut t, p, decimals);
    if q > 0.0 {
        t.push_str(" Q");
        push_fixed(&mut t, q, decimals);
    } else {
        // Q0 turns the naive-CAM merging off (Q would otherwise default to P).
        t.push_str(" Q0");
    }
    t
}

/// `G64 P Q` for `blend` in a program in `units` ([`crate::controller::linuxcnc::g64::blend_words`]).
pub(crate) fn blend_text(blend: Blend, units: Units, decimals: usize) -> String {
    blend_words(blend.p_mm, blend.q_mm, unit_mm(units), decimals)
}

/// Appends [`blend_text`] as a line of its own (`decimals`: the options' decimals).
pub(crate) fn push_blend_line(
    s: &mut Vec<u8>,
    blend: Blend,
    units: Units,
    decimals: usize,
    eol: &str,
) {
    let text = blend_text(blend, units, decimals_for(units, decimals));
    s.extend_from_slice(text.as_bytes());
    s.extend_from_slice(eol.as_bytes());
}

/// The text that sets path mode `mode` in a program in `units`, if it can be written.
pub(crate) fn path_mode_text(mode: PathMode, units: Units) -> Option<String> {
    let scale = unit_mm(units);
    match mode {
        PathMode::Unset => None,
        PathMode::ExactPath => Some("G61".into()),
        PathMode::ExactStop => Some("G61.1".into()),
        PathMode::Blend { p_mm, q_mm } => {
            let mut t = String::from("G64");
            for (l, v) in [(" P", p_mm), (" Q", q_mm)] {
                if v.is_finite() {
                    t.push_str(l);
                    push_fixed(&mut t, v / scale, MAX_DECIMALS);
                }
            }
            Some(t)
        }
    }
}
