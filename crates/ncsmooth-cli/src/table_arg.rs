//! Command-line values read from the libraries' tables: `--method` from
//! [`Method::ALL`] and `--dialect` from [`Dialect::ALL`], with their names and one-line
//! summaries. A method or a dialect added to its table is a value here with no change.

use clap::builder::PossibleValue;
use clap::ValueEnum;
use ncsmooth::smooth::Method;
use ncsmooth_gcode::Dialect;

/// A clap value enum over a library table: `$arg($ty)` for every entry of `$all`.
macro_rules! table_arg {
    ($(#[$doc:meta])* $arg:ident, $ty:ty, $all:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct $arg(pub $ty);

        impl $arg {
            /// Every value, in the table's order.
            const VARIANTS: [$arg; $all.len()] = {
                let mut out = [$arg($all[0]); $all.len()];
                let mut k = 1;
                while k < out.len() {
                    out[k] = $arg($all[k]);
                    k += 1;
                }
                out
            };
        }

        impl ValueEnum for $arg {
            fn value_variants<'a>() -> &'a [Self] {
                &Self::VARIANTS
            }
            fn to_possible_value(&self) -> Option<PossibleValue> {
                Some(PossibleValue::new(self.0.name()).help(self.0.summary()))
            }
        }

        impl From<$arg> for $ty {
            fn from(a: $arg) -> $ty {
                a.0
            }
        }
    };
}

table_arg!(
    /// A smoothing method (`--method`).
    MethodArg,
    Method,
    Method::ALL
);
table_arg!(
    /// A controller dialect (`--dialect`).
    DialectArg,
    Dialect,
    Dialect::ALL
);
