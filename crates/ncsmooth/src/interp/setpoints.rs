//! Setpoint output: the CSV writer (header `t,x,y,z,feed`, then one column per extra axis
//! the program uses; positions `{:.9}` mm, time `{:.9}` s, feed mm/s) and the
//! finite-difference meter that measures velocity, acceleration and jerk **on the values
//! as printed** (each printed number is parsed back), with the actual time column (so a
//! non-uniform step is measured correctly).

use super::sink::{PrintedRow, SetpointSink};
use crate::decimal::POW10_U64;
use crate::geom::Vec3;
use crate::path::{ExtraAxes, EXTRA_AXIS_NAMES};
use serde::Serialize;
use std::io::{self, Write};

/// One setpoint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setpoint {
    /// Time (s).
    pub t: f64,
    /// Position (mm).
    pub p: Vec3,
    /// Planned feed (mm/s).
    pub feed: f64,
    /// Extra-axis values, if the program has extra axes.
    pub extra: Option<ExtraAxes>,
    /// The row follows a jump in position: between the two the controller ran motion
    /// ncsmooth cannot place (a G28 return, a G53 move, a move from an unknown position).
    /// Finite differences restart here.
    pub jump: bool,
}

/// A jump between two setpoint rows (see [`Setpoint::jump`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Jump {
    /// Time of the row after the jump (s).
    pub t_s: f64,
    /// Last position before it (mm).
    pub from: [f64; 3],
    /// First position after it (mm).
    pub to: [f64; 3],
    /// Distance between the two (mm).
    pub distance_mm: f64,
}

/// Finite-difference maxima per axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FdStats {
    /// Largest |velocity| (mm/s).
    pub v_max: [f64; 3],
    /// Largest |acceleration| (mm/s^2).
    pub a_max: [f64; 3],
    /// Time (s) of the largest acceleration.
    pub a_max_t: [f64; 3],
    /// Largest |jerk| (mm/s^3).
    pub j_max: [f64; 3],
    /// Time (s) of the largest jerk.
    pub j_max_t: [f64; 3],
}

/// Streaming finite differences over the last four rows: velocity between rows,
/// acceleration at a row from the two neighbouring velocities (divided by half the span),
/// jerk between two consecutive accelerations.
#[derive(Clone, Debug, Default)]
pub struct FdMeter {
    hist: [(f64, [f64; 3]); 3],
    len: usize,
    last_acc: Option<(f64, [f64; 3])>,
    /// Maxima so far.
    pub stats: FdStats,
}

impl FdMeter {
    /// Forgets the rows so far (the maxima stay): the next row starts a new section.
    pub fn restart(&mut self) {
        self.len = 0;
        self.last_acc = None;
    }

    /// Feeds one row.
    pub fn push(&mut self, t: f64, x: [f64; 3]) {
        if self.len == 3 {
            self.hist.rotate_left(1);
            self.hist[2] = (t, x);
        } else {
            self.hist[self.len] = (t, x);
            self.len += 1;
        }
        let n = self.len;
        if n >= 2 {
            let (t0, x0) = self.hist[n - 2];
            let dt = t - t0;
            if dt > 0.0 {
                // One division per row, not per axis.
                let inv_dt = 1.0 / dt;
                for i in 0..3 {
                    self.stats.v_max[i] = self.stats.v_max[i].max(((x[i] - x0[i]) * inv_dt).abs());
                }
            }
        }
        if n == 3 {
            let (ta, xa) = self.hist[0];
            let (tb, xb) = self.hist[1];
            let (tc, xc) = self.hist[2];
            if tb > ta && tc > tb {
                let (inv_ab, inv_bc) = (1.0 / (tb - ta), 1.0 / (tc - tb));
                let two_inv_ac = 2.0 / (tc - ta);
                let mut acc = [0.0; 3];
                for i in 0..3 {
                    let v1 = (xb[i] - xa[i]) * inv_ab;
                    let v2 = (xc[i] - xb[i]) * inv_bc;
                    acc[i] = (v2 - v1) * two_inv_ac;
                    if acc[i].abs() > self.stats.a_max[i] {
                        self.stats.a_max[i] = acc[i].abs();
                        self.stats.a_max_t[i] = tb;
                    }
                }
                if let Some((tp, ap)) = self.last_acc {
                    if tb > tp {
                        let inv = 1.0 / (tb - tp);
                        for i in 0..3 {
                            let j = ((acc[i] - ap[i]) * inv).abs();
                            if j > self.stats.j_max[i] {
                                self.stats.j_max[i] = j;
                                self.stats.j_max_t[i] = 0.5 * (tb + tp);
                            }
                        }
                    }
                }
                self.last_acc = Some((tb, acc));
            }
        }
    }
}

/// Largest finite-difference speed and acceleration of the extra-axis columns, measured
/// on the printed values like [`FdMeter`] (no limits apply to them).
#[derive(Clone, Debug, Default)]
pub struct ExtraFdMeter {
    hist: Vec<(f64, ExtraAxes)>,
    /// Largest |velocity| per column, in [`EXTRA_AXIS_NAMES`] order (units/s).
    pub v_max: ExtraAxes,
    /// Largest |acceleration| per column (units/s^2).
    pub a_max: ExtraAxes,
}

impl ExtraFdMeter {
    /// Forgets the rows so far (the maxima stay).
    pub fn restart(&mut self) {
        self.hist.clear();
    }

    /// Feeds one row.
    pub fn push(&mut self, t: f64, x: ExtraAxes) {
        if self.hist.len() == 3 {
            self.hist.remove(0);
        }
        self.hist.push((t, x));
        let n = self.hist.len();
        let vel =
            |a: (f64, ExtraAxes), b: (f64, ExtraAxes), i: usize| (b.1[i] - a.1[i]) / (b.0 - a.0);
        if n >= 2 && self.hist[n - 1].0 > self.hist[n - 2].0 {
            for i in 0..x.len() {
                let v = vel(self.hist[n - 2], self.hist[n - 1], i).abs();
                self.v_max[i] = self.v_max[i].max(v);
            }
        }
        if n == 3 && self.hist[1].0 > self.hist[0].0 && self.hist[2].0 > self.hist[1].0 {
            let span = self.hist[2].0 - self.hist[0].0;
            for i in 0..x.len() {
                let a = 2.0
                    * (vel(self.hist[1], self.hist[2], i) - vel(self.hist[0], self.hist[1], i))
                    / span;
                self.a_max[i] = self.a_max[i].max(a.abs());
            }
        }
    }
}

/// The CSV [`SetpointSink`]: writes the header (`t,x,y,z,feed` and one column per extra
/// axis, from [`SetpointSink::begin`]) and one row per setpoint, positions and time to 9
/// decimals, feed to 6. It only formats: what the rows measure is the business of
/// [`super::Measured`], which formats nothing and sees the same printed values
/// ([`printed`]).
pub struct SetpointWriter<W: Write> {
    out: W,
    extra_cols: Vec<usize>,
    line: Vec<u8>,
}

/// Largest magnitude printed through the integer fast path of [`put`] (units of 1e-9).
const FAST_LIMIT: f64 = 9.0e15;
/// The decimal digit pairs "00" to "99".
const DIGIT_PAIRS: [u8; 200] = {
    let mut t = [0u8; 200];
    let mut i = 0;
    while i < 100 {
        t[2 * i] = b'0' + (i / 10) as u8;
        t[2 * i + 1] = b'0' + (i % 10) as u8;
        i += 1;
    }
    t
};

/// Writes the decimal digits of `u` into `buf` ending just before index `end`, at least
/// `min_digits` of them (zero-padded on the left); returns the index of the first digit.
fn digits_rev(buf: &mut [u8], end: usize, mut u: u64, min_digits: usize) -> usize {
    let mut k = end;
    while u >= 100 {
        let d = (u % 100) as usize * 2;
        u /= 100;
        k -= 2;
        buf[k..k + 2].copy_from_slice(&DIGIT_PAIRS[d..d + 2]);
    }
    if u >= 10 {
        let d = u as usize * 2;
        k -= 2;
        buf[k..k + 2].copy_from_slice(&DIGIT_PAIRS[d..d + 2]);
    } else {
        k -= 1;
        buf[k] = b'0' + u as u8;
    }
    while end - k < min_digits {
        k -= 1;
        buf[k] = b'0';
    }
    k
}

/// `x.round() as i64` (half away from zero) for `|x| < 2^53`, without the library call:
/// truncate, then the fraction `x - trunc(x)` is exact (both are representable and the
/// difference is the low bits of `x`).
#[inline]
fn round_half_away(x: f64) -> i64 {
    let t = x as i64;
    let frac = x - t as f64;
    if frac >= 0.5 {
        t + 1
    } else if frac <= -0.5 {
        t - 1
    } else {
        t
    }
}

/// Formats `v` with `decimals` (at most 9) decimals into `line` and returns the value as
/// printed. Fast path: `v` is rounded to an integer `i` of units of `10^-decimals`, which
/// is printed exactly; the printed decimal is then `i / 10^decimals`, and that division is
/// the correctly rounded double of the printed text (both operands are exact), i.e. what
/// parsing the text back would give.
fn put(line: &mut Vec<u8>, v: f64, decimals: usize) -> f64 {
    let scale = POW10_U64[decimals] as f64;
    let x = v * scale;
    if x.is_nan() || x.abs() >= FAST_LIMIT {
        let text = format!("{v:.decimals$}");
        line.extend_from_slice(text.as_bytes());
        return text.parse().unwrap_or(f64::NAN);
    }
    let i = round_half_away(x);
    if i < 0 {
        line.push(b'-');
    }
    // |i| as integer and fraction digits (the fraction zero-padded to `decimals`), written
    // from the right two digits at a time.
    let u = i.unsigned_abs();
    let unit = POW10_U64[decimals];
    let mut buf = [0u8; 32];
    let mut k = buf.len();
    if decimals > 0 {
        k = digits_rev(&mut buf, k, u % unit, decimals);
        k -= 1;
        buf[k] = b'.';
    }
    k = digits_rev(&mut buf, k, u / unit, 1);
    line.extend_from_slice(&buf[k..]);
    if i == 0 {
        // "-0.000..." is never printed; the value is zero.
        return 0.0;
    }
    i as f64 / scale
}

/// Decimals of the printed positions, times and extra-axis values.
pub const POSITION_DECIMALS: usize = 9;
/// Decimals of the printed feed.
pub const FEED_DECIMALS: usize = 6;

/// The value [`SetpointWriter`] prints for `v` at `decimals` (at most 9) decimals, as a
/// double: what reading the CSV back gives, without formatting it (the same rounding as
/// the writer's own, checked by the tests on every precision).
#[inline]
pub fn printed(v: f64, decimals: usize) -> f64 {
    let scale = POW10_U64[decimals] as f64;
    let x = v * scale;
    if x.is_nan() || x.abs() >= FAST_LIMIT {
        return format!("{v:.decimals$}").parse().unwrap_or(f64::NAN);
    }
    let i = round_half_away(x);
    if i == 0 {
        return 0.0;
    }
    i as f64 / scale
}

impl<W: Write> SetpointWriter<W> {
    /// A writer into `out`; the header is written by [`SetpointSink::begin`].
    pub fn new(out: W) -> Self {
        SetpointWriter {
            out,
            extra_cols: Vec::new(),
            line: Vec::with_capacity(128),
        }
    }
    /// Flushes and returns the output.
    pub fn into_inner(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

impl<W: Write> SetpointSink for SetpointWriter<W> {
    /// Writes the header: `t,x,y,z,feed`, then the extra columns `extra_axes_mask` selects
    /// ([`EXTRA_AXIS_NAMES`], in lower case).
    fn begin(&mut self, extra_axes_mask: u8) -> io::Result<()> {
        self.extra_cols = (0..EXTRA_AXIS_NAMES.len())
            .filter(|i| extra_axes_mask & (1 << i) != 0)
            .collect();
        let mut header = String::from("t,x,y,z,feed");
        for &i in &self.extra_cols {
            header.push(',');
            header.push(EXTRA_AXIS_NAMES[i].to_ascii_lowercase());
        }
        header.push('\n');
        self.out.write_all(header.as_bytes())
    }
    /// Writes one row.
    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        self.push_printed(sp).map(|_| ())
    }
    /// Writes one row and returns its time and position as printed.
    #[inline]
    fn push_printed(&mut self, sp: &Setpoint) -> io::Result<Option<PrintedRow>> {
        self.line.clear();
        let t = put(&mut self.line, sp.t, POSITION_DECIMALS);
        let mut x = [0.0; 3];
        for i in 0..3 {
            self.line.push(b',');
            x[i] = put(&mut self.line, sp.p[i], POSITION_DECIMALS);
        }
        self.line.push(b',');
        put(&mut self.line, sp.feed, FEED_DECIMALS);
        for &i in &self.extra_cols {
            self.line.push(b',');
            put(
                &mut self.line,
                sp.extra.map_or(0.0, |e| e[i]),
                POSITION_DECIMALS,
            );
        }
        self.line.push(b'\n');
        self.out.write_all(&self.line)?;
        Ok(Some((t, x)))
    }
    fn finish(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fd_of_a_parabola_and_a_cubic() {
        // x = 3 t^2 -> a = 6; y = t^3 -> jerk 6; uniform step 1 ms.
        let mut fd = FdMeter::default();
        for k in 0..100 {
            let t = k as f64 * 1e-3;
            fd.push(t, [3.0 * t * t, t * t * t, 0.0]);
        }
        assert!((fd.stats.a_max[0] - 6.0).abs() < 1e-6);
        assert!((fd.stats.j_max[1] - 6.0).abs() < 1e-3);
        assert!(fd.stats.j_max[0] < 1e-3);
        // Non-uniform last step.
        let mut fd = FdMeter::default();
        for t in [0.0, 1e-3, 2e-3, 2.4e-3] {
            fd.push(t, [3.0 * t * t, 0.0, 0.0]);
        }
        assert!((fd.stats.a_max[0] - 6.0).abs() < 1e-6);
    }

    #[test]
    fn rounding_is_the_library_round() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.49999999999999994,
        ];
        for k in [1.0f64, 7.0, 1e3, 123456789.0, 4.5e15, 8.9e15] {
            for base in [k + 0.5, -(k + 0.5), k, -k] {
                xs.extend([base, base.next_up(), base.next_down()]);
            }
        }
        let mut r = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..100_000 {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            let u = (r >> 11) as f64 / (1u64 << 53) as f64;
            let mag = 10f64.powf(u * 15.9);
            xs.push(if r & 1 == 0 { mag } else { -mag });
        }
        for x in xs {
            assert_eq!(round_half_away(x), x.round() as i64, "{x:e}");
        }
    }

    #[test]
    fn fast_formatting_matches_std() {
        let vals = [
            0.0,
            -0.0,
            1.5,
            -1.5,
            1e-10,
            -4e-10,
            6e-10,
            123.456789012345,
            -98765.4321,
            0.1 + 0.2,
            2.5e-9,
            1e7,
            -3e9,
            1e300,
            f64::NAN,
        ];
        for v in vals {
            let mut a = Vec::new();
            let got = put(&mut a, v, 9);
            let a = String::from_utf8(a).unwrap();
            let b = format!("{v:.9}");
            let parsed: f64 = a.parse().unwrap_or(f64::NAN);
            if v.is_nan() {
                assert!(got.is_nan());
                continue;
            }
            // Same text up to the sign of zero and ties, and the returned value is the
            // text parsed back.
            let bv: f64 = b.parse().unwrap();
            assert!(
                (parsed - bv).abs() <= 1e-9 * (1.0 + v.abs() * 1e-7),
                "{v}: {a} vs {b}"
            );
            assert_eq!(got, parsed, "{v}: {a}");
            assert_eq!(printed(v, 9).to_bits(), got.to_bits(), "{v}");
        }
    }

    #[test]
    fn fast_formatting_matches_std_at_every_precision() {
        // Deterministic pseudo-random values over many magnitudes, every precision: the
        // same text as `{:.N}` except where the scaled value is within rounding of a tie.
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for n in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let mant = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            let v = mant * 10f64.powi((n % 14) - 4);
            for decimals in 0..=9 {
                let mut a = Vec::new();
                let got = put(&mut a, v, decimals);
                let a = String::from_utf8(a).unwrap();
                let b = format!("{v:.decimals$}");
                let scaled = v * POW10_U64[decimals] as f64;
                let near_tie = (scaled.abs().fract() - 0.5).abs() < 1e-6;
                if !near_tie {
                    let b = if b.starts_with("-") && b.trim_matches(['-', '0', '.']).is_empty() {
                        b[1..].to_string()
                    } else {
                        b
                    };
                    assert_eq!(a, b, "{v} at {decimals}");
                }
                assert_eq!(got, a.parse::<f64>().unwrap(), "{v} at {decimals}: {a}");
                // The measuring adapter's rounding is the writer's.
                assert_eq!(printed(v, decimals).to_bits(), got.to_bits(), "{v}");
            }
        }
    }

    #[test]
    fn csv_rows_and_extra_columns() {
        let mut w = SetpointWriter::new(Vec::new());
        w.begin(1 << 6).unwrap();
        w.push(&Setpoint {
            jump: false,
            t: 0.0,
            p: Vec3::new(1.0, 2.0, 3.0),
            feed: 0.0,
            extra: Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]),
        })
        .unwrap();
        let s = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(
            s,
            "t,x,y,z,feed,e\n0.000000000,1.000000000,2.000000000,3.000000000,0.000000,0.500000000\n"
        );
    }
}
