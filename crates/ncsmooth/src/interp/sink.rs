//! Where setpoints go: the [`SetpointSink`] trait and its implementations.
//!
//! [`super::execute_into`] hands every setpoint, in time order, to a sink of the caller's
//! choosing, on a thread of its own (hence `Send`):
//!
//! * [`super::SetpointWriter`]: CSV text into any [`std::io::Write`] (what `plan
//!   --setpoints` writes; [`super::execute`] is `execute_into` with this sink);
//! * `Vec<Setpoint>`: every row in memory (mind the size: one row per period, 64 bytes
//!   each, a thousand rows per second of motion at a 1 ms period);
//! * [`FnSink`]: a callback per row (to decimate, forward or stop early: an error stops
//!   the run and comes back as [`super::PlanError::Io`]);
//! * [`NullSink`]: nothing (only the report is wanted);
//! * `(A, B)`: both, in order; `Option<S>`: `S` when there is one.
//!
//! Whatever the sink, [`Measured`] wraps it inside the run: the report's kinematics
//! (finite-difference velocity, acceleration and jerk per axis, jumps, first and last
//! row) are measured on the values **as the CSV prints them** ([`super::printed`]: 1e-9
//! mm, 1e-9 s), so the report is the same whichever sink the rows went to. The sinks get
//! the setpoints as computed (unrounded; they differ from the printed values by at most
//! 0.5e-9 mm).
//!
//! The trait is deliberately small: `begin` (the columns), `push` (a row), `finish`.

use super::setpoints::{printed, ExtraFdMeter, FdMeter, Jump, Setpoint, POSITION_DECIMALS};
use std::io;

/// A consumer of setpoint rows, in time order (see the module doc).
pub trait SetpointSink {
    /// Called once before the first row with the extra-axis columns the program uses:
    /// bit `i` set for [`crate::path::EXTRA_AXIS_NAMES`]`[i]`. Default: nothing.
    fn begin(&mut self, extra_axes_mask: u8) -> io::Result<()> {
        let _ = extra_axes_mask;
        Ok(())
    }
    /// One row. An error stops the run.
    fn push(&mut self, sp: &Setpoint) -> io::Result<()>;
    /// One row, as [`push`](Self::push); a sink that prints the row's time and position
    /// anyway returns them as printed ([`super::printed`]), so [`Measured`] need not round
    /// them again (the CSV writer: the rounding is a measurable share of a large plan's
    /// writing thread). Default: `push`, then `None`.
    #[inline]
    fn push_printed(&mut self, sp: &Setpoint) -> io::Result<Option<PrintedRow>> {
        self.push(sp).map(|()| None)
    }
    /// Called once after the last row (flush here). Default: nothing.
    fn finish(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl SetpointSink for Vec<Setpoint> {
    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        Vec::push(self, *sp);
        Ok(())
    }
}

/// Both sinks, each row to the first and then the second (e.g. the CSV and an in-memory
/// summary in one run).
impl<A: SetpointSink, B: SetpointSink> SetpointSink for (A, B) {
    fn begin(&mut self, extra_axes_mask: u8) -> io::Result<()> {
        self.0.begin(extra_axes_mask)?;
        self.1.begin(extra_axes_mask)
    }
    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        self.0.push(sp)?;
        self.1.push(sp)
    }
    #[inline]
    fn push_printed(&mut self, sp: &Setpoint) -> io::Result<Option<PrintedRow>> {
        let printed = self.0.push_printed(sp)?;
        self.1.push(sp)?;
        Ok(printed)
    }
    fn finish(&mut self) -> io::Result<()> {
        self.0.finish()?;
        self.1.finish()
    }
}

/// The sink when there is one, nothing otherwise.
impl<S: SetpointSink> SetpointSink for Option<S> {
    fn begin(&mut self, extra_axes_mask: u8) -> io::Result<()> {
        self.as_mut().map_or(Ok(()), |s| s.begin(extra_axes_mask))
    }
    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        self.as_mut().map_or(Ok(()), |s| s.push(sp))
    }
    #[inline]
    fn push_printed(&mut self, sp: &Setpoint) -> io::Result<Option<PrintedRow>> {
        self.as_mut().map_or(Ok(None), |s| s.push_printed(sp))
    }
    fn finish(&mut self) -> io::Result<()> {
        self.as_mut().map_or(Ok(()), |s| s.finish())
    }
}

/// A row's time (s) and X, Y, Z (mm) as the CSV prints them.
pub type PrintedRow = (f64, [f64; 3]);

/// A sink that calls `F` with every row.
///
/// ```
/// use ncsmooth::feed::PlanOptions;
/// use ncsmooth::geom::Vec3;
/// use ncsmooth::interp::{execute_into, FnSink, InterpOptions};
/// use ncsmooth::path::Toolpath;
///
/// let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)], None);
/// let mut fastest = 0.0f64;
/// let sink = FnSink(|sp: &ncsmooth::interp::Setpoint| {
///     fastest = fastest.max(sp.feed);
///     Ok(())
/// });
/// let (report, _) =
///     execute_into(&tp, &PlanOptions::default(), &InterpOptions::default(), sink).unwrap();
/// assert!(fastest > 0.0 && fastest <= 50.0 + 1e-9);
/// assert!(report.limits_held);
/// ```
pub struct FnSink<F>(pub F);

impl<F: FnMut(&Setpoint) -> io::Result<()>> SetpointSink for FnSink<F> {
    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        (self.0)(sp)
    }
}

/// A sink that drops every row.
#[derive(Clone, Copy, Debug, Default)]
pub struct NullSink;

impl SetpointSink for NullSink {
    #[inline]
    fn push(&mut self, _: &Setpoint) -> io::Result<()> {
        Ok(())
    }
}

/// The measuring adapter: measures every row as printed (see the module doc),
/// then passes it on to `inner` unchanged.
pub struct Measured<S> {
    /// The sink the rows go to.
    pub inner: S,
    /// Extra-axis columns measured (indices into [`crate::path::EXTRA_AXIS_NAMES`]).
    extra_cols: Vec<usize>,
    /// Finite differences of the printed rows.
    pub fd: FdMeter,
    /// Finite differences of the printed extra-axis columns.
    pub extra_fd: ExtraFdMeter,
    /// Rows passed on.
    pub rows: usize,
    /// Last row as printed: time and position.
    pub last: Option<(f64, [f64; 3])>,
    /// First row as printed.
    pub first: Option<(f64, [f64; 3])>,
    /// Jumps between rows, in order.
    pub jumps: Vec<Jump>,
}

impl<S> Measured<S> {
    /// Measures the rows going to `inner`.
    pub fn new(inner: S) -> Self {
        Measured {
            inner,
            extra_cols: Vec::new(),
            fd: FdMeter::default(),
            extra_fd: ExtraFdMeter::default(),
            rows: 0,
            last: None,
            first: None,
            jumps: Vec::new(),
        }
    }
}

impl<S: SetpointSink> SetpointSink for Measured<S> {
    fn begin(&mut self, extra_axes_mask: u8) -> io::Result<()> {
        self.extra_cols = (0..crate::path::EXTRA_AXIS_NAMES.len())
            .filter(|i| extra_axes_mask & (1 << i) != 0)
            .collect();
        self.inner.begin(extra_axes_mask)
    }

    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        let (t, x) = match self.inner.push_printed(sp)? {
            Some(row) => row,
            None => (
                printed(sp.t, POSITION_DECIMALS),
                [0, 1, 2].map(|i| printed(sp.p[i], POSITION_DECIMALS)),
            ),
        };
        if sp.jump {
            self.fd.restart();
            self.extra_fd.restart();
            if let Some((_, from)) = self.last {
                let d = ((x[0] - from[0]).powi(2)
                    + (x[1] - from[1]).powi(2)
                    + (x[2] - from[2]).powi(2))
                .sqrt();
                self.jumps.push(Jump {
                    t_s: t,
                    from,
                    to: x,
                    distance_mm: d,
                });
            }
        }
        if !self.extra_cols.is_empty() {
            let mut e = [0.0; 7];
            for &i in &self.extra_cols {
                e[i] = printed(sp.extra.map_or(0.0, |e| e[i]), POSITION_DECIMALS);
            }
            self.extra_fd.push(sp.t, e);
        }
        self.fd.push(t, x);
        self.rows += 1;
        if self.first.is_none() {
            self.first = Some((t, x));
        }
        self.last = Some((t, x));
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        self.inner.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::super::setpoints::SetpointWriter;
    use super::*;
    use crate::geom::Vec3;

    fn row(t: f64, x: f64, jump: bool) -> Setpoint {
        Setpoint {
            t,
            p: Vec3::new(x, 0.5 * x, 0.0),
            feed: 1.0,
            extra: None,
            jump,
        }
    }

    #[test]
    fn every_sink_gets_the_same_rows_and_the_same_measurements() {
        // x = 3 t^2 (acceleration 6 mm/s^2) with a jump in the middle.
        let rows: Vec<Setpoint> = (0..50)
            .map(|k| {
                let t = k as f64 * 1e-3;
                row(t, 3.0 * t * t + if k >= 25 { 1.0 } else { 0.0 }, k == 25)
            })
            .collect();
        let feed = |sink: &mut dyn SetpointSink| {
            sink.begin(0).unwrap();
            for r in &rows {
                sink.push(r).unwrap();
            }
            sink.finish().unwrap();
        };
        let mut csv = Measured::new(SetpointWriter::new(Vec::new()));
        feed(&mut csv);
        let mut vec = Measured::new(Vec::new());
        feed(&mut vec);
        let mut both = Measured::new((Vec::new(), Some(Vec::new())));
        feed(&mut both);
        assert_eq!(both.inner.0, rows);
        assert_eq!(both.inner.1.as_ref(), Some(&rows));
        let mut count = 0usize;
        let mut cb = Measured::new(FnSink(|_: &Setpoint| {
            count += 1;
            Ok(())
        }));
        feed(&mut cb);
        let cb_fd = cb.fd.stats;
        let cb_rows = cb.rows;
        drop(cb);
        assert_eq!(count, rows.len());
        assert_eq!(vec.inner, rows);
        assert_eq!(csv.fd.stats, vec.fd.stats);
        assert_eq!(cb_fd, vec.fd.stats);
        assert_eq!((csv.rows, cb_rows), (50, 50));
        assert_eq!(vec.jumps.len(), 1);
        assert!((vec.jumps[0].distance_mm - 1.25f64.sqrt()).abs() < 1e-3);
        // Finite differences restart at the jump: the acceleration stays 6.
        assert!(
            (vec.fd.stats.a_max[0] - 6.0).abs() < 1e-3,
            "{:?}",
            vec.fd.stats
        );
        let text = String::from_utf8(csv.inner.into_inner().unwrap()).unwrap();
        assert_eq!(text.lines().count(), 51);
        assert!(text.starts_with("t,x,y,z,feed\n0.000000000,"));
    }

    #[test]
    fn a_failing_sink_stops_with_its_error() {
        let mut m = Measured::new(FnSink(|sp: &Setpoint| {
            if sp.t > 1.0 {
                Err(io::Error::other("enough"))
            } else {
                Ok(())
            }
        }));
        m.push(&row(0.5, 0.0, false)).unwrap();
        assert!(m.push(&row(1.5, 0.0, false)).is_err());
        assert_eq!(m.rows, 1, "a refused row is not counted");
    }

    #[test]
    fn the_csv_writer_returns_the_values_it_prints() {
        let mut w = SetpointWriter::new(Vec::new());
        let sp = row(0.123456789012, 1.0 / 3.0, false);
        let (t, x) = w.push_printed(&sp).unwrap().unwrap();
        assert_eq!(t, printed(sp.t, POSITION_DECIMALS));
        assert_eq!(x, [0, 1, 2].map(|i| printed(sp.p[i], POSITION_DECIMALS)));
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let cols: Vec<f64> = text.trim().split(',').map(|c| c.parse().unwrap()).collect();
        assert_eq!(&cols[..4], &[t, x[0], x[1], x[2]]);
    }
}
