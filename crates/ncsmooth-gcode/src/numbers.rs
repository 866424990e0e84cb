//! Decimal formatting of the numbers the writers print (coordinates, feeds, `G64` words)
//! and the rounding that printing them costs. Below the reader and the writers: both print
//! numbers with [`push_fixed`].

use ncsmooth::decimal::POW10_U64;
use ncsmooth::path::Units;
use std::fmt::Write as _;

/// Digits `E` gets beyond the coordinates' (5 at the default 4, as slicers write it): a
/// block of a smoothed print extrudes a few thousandths of a millimetre of filament, and
/// rounding that to 4 decimals changed each block's flow by up to a few per cent.
pub(crate) const E_EXTRA_DECIMALS: usize = 1;

/// Most digits after the point the writer prints; more are clamped to this. 1e-12 mm is
/// below what an f64 coordinate of a few metres resolves.
pub const MAX_DECIMALS: usize = 12;

/// Most digits [`push_fixed`] prints: coordinates at [`MAX_DECIMALS`] plus the extra
/// digits of arc centres.
pub(crate) const PRINT_DECIMALS_MAX: usize = MAX_DECIMALS + CENTRE_EXTRA_DECIMALS;

/// Largest distance (mm) a point moves when each coordinate is rounded to `decimals`
/// digits (half a unit of the last digit on each of the three axes).
pub fn rounding_mm(decimals: usize) -> f64 {
    0.5 * 0.1f64.powi(decimals.min(MAX_DECIMALS) as i32) * 3f64.sqrt()
}

/// Extra digits for the I/J/K centre offsets: the reader's centre is then essentially
/// exact relative to the rounded end points, so the arc between them deviates from the
/// original by about the end-point rounding only (with the same digits as the
/// coordinates, the centre rounding adds up to the same amount again, and arc midpoints
/// of a 6-decimal round trip could move by up to 1.4e-6 mm).
pub(crate) const CENTRE_EXTRA_DECIMALS: usize = 2;

/// Appends `r * 10^-decimals`: its digits with the point inserted, trailing zeros of the
/// fraction dropped (`0` for zero, never `-0`).
pub(crate) fn push_scaled(s: &mut String, r: i128, decimals: usize) {
    if r == 0 {
        s.push('0');
        return;
    }
    if r < 0 {
        s.push('-');
    }
    let p = 10u128.pow(decimals as u32);
    let u = r.unsigned_abs();
    let (int, mut frac) = (u / p, u % p);
    let _ = write!(s, "{int}");
    if frac != 0 {
        let mut width = decimals;
        while frac % 10 == 0 {
            frac /= 10;
            width -= 1;
        }
        let _ = write!(s, ".{frac:0width$}");
    }
}

/// A decimal as printed ([`push_fixed`]) as an integer count of `10^-decimals`.
fn scaled_decimal(s: &str, decimals: usize) -> Option<i128> {
    let (neg, digits) = match s.strip_prefix('-') {
        Some(d) => (true, d),
        None => (false, s),
    };
    let (int, frac) = digits.split_once('.').unwrap_or((digits, ""));
    if frac.len() > decimals {
        return None;
    }
    let mut v: i128 = int.parse().ok()?;
    for k in 0..decimals {
        let d = frac.as_bytes().get(k).map_or(0, |b| i128::from(b - b'0'));
        v = v * 10 + d;
    }
    Some(if neg { -v } else { v })
}

/// `a + sign * b` for two printed decimals, exactly (the digits of the longer fraction,
/// trailing zeros dropped); `None` when one is not a printed decimal.
pub(crate) fn decimal_sum(a: &str, b: &str, sign: i128) -> Option<String> {
    let frac_len = |s: &str| s.split_once('.').map_or(0, |(_, f)| f.len());
    let d = frac_len(a).max(frac_len(b));
    let sum = scaled_decimal(a, d)? + sign * scaled_decimal(b, d)?;
    let mut out = String::new();
    push_scaled(&mut out, sum, d);
    Some(out)
}

/// Appends `v` with at most `decimals` digits after the point, without trailing zeros,
/// never `-0` and never in exponent notation.
///
/// Fast path (the writer formats millions of numbers, and `{:.N}` falls back to exact
/// big-number arithmetic for most of them): when `|v| 10^decimals < 9e15`, the value is
/// scaled, rounded half away from zero to an integer and printed with the point
/// inserted. The scaling itself rounds, so a value within one ulp of a tie may round
/// the other way than exact decimal rounding would: the printed value is still within
/// half a unit of the last digit (plus an ulp) of `v`. Other values use `{:.N}`.
/// `decimals` is clamped to `PRINT_DECIMALS_MAX`.
pub fn push_fixed(s: &mut String, v: f64, decimals: usize) {
    let decimals = decimals.min(PRINT_DECIMALS_MAX);
    if decimals < POW10_U64.len() && v.is_finite() {
        let p = POW10_U64[decimals];
        let x = (v * p as f64).round();
        if x.abs() < 9.0e15 {
            push_scaled(s, i128::from(x as i64), decimals);
            return;
        }
    }
    let start = s.len();
    let _ = write!(s, "{:.*}", decimals, v);
    if s[start..].contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if &s[start..] == "-0" {
        s.truncate(start);
        s.push('0');
    }
}

/// Decimals written in `units` for `decimals` millimetre decimals.
pub fn decimals_for(units: Units, decimals: usize) -> usize {
    match units {
        Units::Millimetres => decimals,
        Units::Inches => (decimals + 1).min(MAX_DECIMALS),
    }
}

/// Largest distance (mm) a point moves when written with `decimals` in `units`.
pub fn rounding_mm_for(units: Units, decimals: usize) -> f64 {
    rounding_mm(decimals_for(units, decimals)) * unit_mm(units)
}

/// Millimetres per unit of `units`.
pub(crate) fn unit_mm(units: Units) -> f64 {
    match units {
        Units::Millimetres => 1.0,
        Units::Inches => 25.4,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers() {
        let f = |v: f64, d: usize| {
            let mut s = String::new();
            push_fixed(&mut s, v, d);
            s
        };
        assert_eq!(f(1.5, 4), "1.5");
        assert_eq!(f(-0.00001, 4), "0");
        assert_eq!(f(-0.0, 4), "0");
        assert_eq!(f(10.0, 4), "10");
        assert_eq!(f(100.0, 0), "100");
        assert_eq!(f(1e20, 2), "100000000000000000000");
        assert_eq!(f(-2.25, 1), "-2.3"); // ties away from zero
        assert_eq!(f(1234.56789, 6), "1234.56789");
        assert_eq!(f(0.05, 4), "0.05");
        assert_eq!(f(-0.000123, 6), "-0.000123");
        assert_eq!(f(3.0001, 4), "3.0001");
        assert_eq!(f(1e300, 4).len(), 301); // slow path, no exponent
        assert_eq!(f(-1e300, 2).chars().next(), Some('-'));
        // Agrees with exact formatting away from ties.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..10_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = (state % 2_000_000_000) as f64 / 1e4 - 1e5 + 0.123_456_789;
            let mut exact = format!("{v:.4}");
            while exact.contains('.') && (exact.ends_with('0') || exact.ends_with('.')) {
                exact.pop();
            }
            assert_eq!(f(v, 4), exact);
        }
    }
}
