//! Setpoint output: the CSV writer (header `t,x,y,z,feed`, then one column per extra axis
//! the program uses; positions `{:.9}` mm, time `{:.9}` s, feed mm/s) and the
//! finite-difference meter that measures velocity, acceleration and jerk **on the values
//! as printed** (each printed number is parsed back), with the actual time column (so a
//! non-uniform step is measured correctly).

use crate::geom::Vec3;
use crate::path::{ExtraAxes, EXTRA_AXIS_NAMES};
use serde::Serialize;
use std::fmt::Write as _;
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
    hist: Vec<(f64, [f64; 3])>,
    last_acc: Option<(f64, [f64; 3])>,
    /// Maxima so far.
    pub stats: FdStats,
}

impl FdMeter {
    /// Feeds one row.
    pub fn push(&mut self, t: f64, x: [f64; 3]) {
        self.hist.push((t, x));
        if self.hist.len() > 3 {
            self.hist.remove(0);
        }
        let n = self.hist.len();
        if n >= 2 {
            let (t0, x0) = self.hist[n - 2];
            let dt = t - t0;
            if dt > 0.0 {
                for i in 0..3 {
                    self.stats.v_max[i] = self.stats.v_max[i].max(((x[i] - x0[i]) / dt).abs());
                }
            }
        }
        if n == 3 {
            let (ta, xa) = self.hist[0];
            let (tb, xb) = self.hist[1];
            let (tc, xc) = self.hist[2];
            if tb > ta && tc > tb {
                let mut acc = [0.0; 3];
                for i in 0..3 {
                    let v1 = (xb[i] - xa[i]) / (tb - ta);
                    let v2 = (xc[i] - xb[i]) / (tc - tb);
                    acc[i] = 2.0 * (v2 - v1) / (tc - ta);
                    if acc[i].abs() > self.stats.a_max[i] {
                        self.stats.a_max[i] = acc[i].abs();
                        self.stats.a_max_t[i] = tb;
                    }
                }
                if let Some((tp, ap)) = self.last_acc {
                    if tb > tp {
                        for i in 0..3 {
                            let j = ((acc[i] - ap[i]) / (tb - tp)).abs();
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

/// Writes setpoint rows as CSV and measures them.
pub struct SetpointWriter<W: Write> {
    out: W,
    extra_cols: Vec<usize>,
    line: String,
    /// Finite differences of the printed rows.
    pub fd: FdMeter,
    /// Rows written.
    pub rows: usize,
    /// Last row as printed: time and position.
    pub last: Option<(f64, [f64; 3])>,
    /// First row as printed.
    pub first: Option<(f64, [f64; 3])>,
}

/// Formats `v` with 9 decimals into `line` and returns the value as printed.
fn put(line: &mut String, v: f64) -> f64 {
    let start = line.len();
    let _ = write!(line, "{v:.9}");
    line[start..].parse().unwrap_or(f64::NAN)
}

impl<W: Write> SetpointWriter<W> {
    /// A writer; writes the header now. `extra_axes_mask` selects the extra columns
    /// ([`EXTRA_AXIS_NAMES`], written in lower case).
    pub fn new(mut out: W, extra_axes_mask: u8) -> io::Result<Self> {
        let extra_cols: Vec<usize> = (0..EXTRA_AXIS_NAMES.len())
            .filter(|i| extra_axes_mask & (1 << i) != 0)
            .collect();
        let mut header = String::from("t,x,y,z,feed");
        for &i in &extra_cols {
            header.push(',');
            header.push(EXTRA_AXIS_NAMES[i].to_ascii_lowercase());
        }
        header.push('\n');
        out.write_all(header.as_bytes())?;
        Ok(SetpointWriter {
            out,
            extra_cols,
            line: String::with_capacity(128),
            fd: FdMeter::default(),
            rows: 0,
            last: None,
            first: None,
        })
    }
    /// Writes one row.
    pub fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        self.line.clear();
        let t = put(&mut self.line, sp.t);
        let mut x = [0.0; 3];
        for i in 0..3 {
            self.line.push(',');
            x[i] = put(&mut self.line, sp.p[i]);
        }
        let _ = write!(self.line, ",{:.6}", sp.feed);
        for &i in &self.extra_cols {
            let v = sp.extra.map_or(0.0, |e| e[i]);
            let _ = write!(self.line, ",{v:.9}");
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())?;
        self.fd.push(t, x);
        self.rows += 1;
        if self.first.is_none() {
            self.first = Some((t, x));
        }
        self.last = Some((t, x));
        Ok(())
    }
    /// Flushes and returns the sink.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
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
    fn csv_rows_and_extra_columns() {
        let mut w = SetpointWriter::new(Vec::new(), 1 << 6).unwrap();
        w.push(&Setpoint {
            t: 0.0,
            p: Vec3::new(1.0, 2.0, 3.0),
            feed: 0.0,
            extra: Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]),
        })
        .unwrap();
        let s = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(
            s,
            "t,x,y,z,feed,e\n0.000000000,1.000000000,2.000000000,3.000000000,0.000000,0.500000000\n"
        );
    }
}
