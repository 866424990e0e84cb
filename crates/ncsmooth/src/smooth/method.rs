//! The table of smoothing methods: one row per method, the only list of their names.
//!
//! Every method has the same entry point, [`MethodSpec::smooth`]: it takes one chain of
//! feed moves (after the arc joints and, for the methods that have one, the run mode) and
//! returns its moves within the chain's tolerance. The row also says which curve blends the
//! chain's arc joints ([`arc_joint`]) and which family the run mode fits
//! ([`run_mode`]); [`super::smooth_chain`] runs the same three steps for every method.
//!
//! Adding a method: its module, a variant of [`Method`], a row of [`SPECS`] (in the
//! variant's order), and its options in [`SmoothOptions`] if it has any. The command line,
//! `compare`'s rows and the report's colours are read from [`Method::ALL`].

use super::{
    arc_corner, arc_joint, bspline_corner, nurbs_hybrid, passthrough, run_mode, trig_corner,
};
use super::{Chain, SmoothOptions, SmoothReport};
use crate::path::Move;
use serde::Serialize;

/// Smoothing method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
pub enum Method {
    /// No smoothing.
    #[default]
    None,
    /// Cubic B-spline corners (Guo et al.).
    Bspline,
    /// Circular-arc corners (Wu et al.).
    Arc,
    /// NURBS-circular hybrid (Wu et al.).
    Nurbs,
    /// Cubic trigonometric spline (Tao et al.).
    Trig,
}

/// The entry point every method implements: one chain in, its smoothed moves out, the
/// corner counts added to the report.
pub(crate) type SmoothChainFn = fn(&Chain<'_>, &SmoothOptions, &mut SmoothReport) -> Vec<Move>;

/// One row of the method table.
pub(crate) struct MethodSpec {
    /// The method of this row (the rows are in [`Method`]'s order).
    pub method: Method,
    /// Command-line name.
    pub name: &'static str,
    /// One line for `--help` and the report: what the method does and whose it is.
    pub summary: &'static str,
    /// Curve of the blends at the chain's arc joints; `None`: the chain is left as it is.
    pub joint_curve: Option<arc_joint::BlendCurve>,
    /// Family the run mode fits runs of micro-corners in before the method's corners;
    /// `None`: no run mode step (the method fits its runs itself, or has none).
    pub run_family: Option<run_mode::Family>,
    /// The method on one chain.
    pub smooth: SmoothChainFn,
}

/// The method table, in [`Method`]'s order.
pub(crate) const SPECS: [MethodSpec; 5] = [
    MethodSpec {
        method: Method::None,
        name: "none",
        summary: "No smoothing (the program as written).",
        joint_curve: None,
        run_family: None,
        smooth: |chain, _, _| passthrough(chain),
    },
    MethodSpec {
        method: Method::Bspline,
        name: "bspline",
        summary: "Cubic B-spline corner transitions in a tolerance band (Guo et al.).",
        joint_curve: Some(arc_joint::BlendCurve::Bezier),
        run_family: Some(run_mode::Family::Bezier),
        smooth: |chain, opts, report| {
            bspline_corner::smooth_chain(chain, opts, &opts.bspline, report)
        },
    },
    MethodSpec {
        method: Method::Arc,
        name: "arc",
        summary: "Circular-arc corner transitions (Wu et al.), runs of micro-lines as arc \
                  splines.",
        joint_curve: Some(arc_joint::BlendCurve::Bezier),
        run_family: Some(run_mode::Family::Arcs),
        smooth: arc_corner::smooth_arc,
    },
    MethodSpec {
        method: Method::Nurbs,
        name: "nurbs",
        summary: "NURBS fitting of micro-line runs plus arc corners (Wu et al.).",
        joint_curve: Some(arc_joint::BlendCurve::Bezier),
        run_family: None,
        smooth: nurbs_hybrid::smooth_nurbs,
    },
    MethodSpec {
        method: Method::Trig,
        name: "trig",
        summary: "Cubic trigonometric spline (Tao et al.).",
        joint_curve: Some(arc_joint::BlendCurve::Trig),
        run_family: Some(run_mode::Family::Trig),
        smooth: trig_corner::smooth_chain_trig,
    },
];

impl Method {
    /// Every method, in the table's order (`None` first: the reference of a comparison).
    pub const ALL: [Method; SPECS.len()] = {
        let mut all = [Method::None; SPECS.len()];
        let mut k = 0;
        while k < SPECS.len() {
            all[k] = SPECS[k].method;
            k += 1;
        }
        all
    };

    /// The method's row of the table.
    pub(crate) fn spec(self) -> &'static MethodSpec {
        &SPECS[self as usize]
    }

    /// Parses a method name as used on the command line.
    pub fn from_name(s: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Command-line name.
    pub fn name(self) -> &'static str {
        self.spec().name
    }

    /// One line: what the method does and whose it is (the paper).
    pub fn summary(self) -> &'static str {
        self.spec().summary
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rows_are_in_the_variants_order_and_names_are_unique() {
        for (k, spec) in SPECS.iter().enumerate() {
            assert_eq!(spec.method as usize, k, "row {k} is {:?}", spec.method);
            assert_eq!(Method::from_name(spec.name), Some(spec.method));
        }
        assert_eq!(Method::ALL[0], Method::None);
        assert_eq!(Method::from_name("spline"), None);
    }
}
