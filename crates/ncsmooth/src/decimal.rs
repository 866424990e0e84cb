//! Shared pieces of the fixed-point decimal formatting of the setpoint CSV
//! ([`crate::interp::SetpointWriter`]) and the G-code writer (`ncsmooth-gcode`).
//!
//! The two print different formats on purpose, each once: G-code words with at most `N`
//! decimals, trailing zeros dropped, never `-0` (`ncsmooth_gcode::numbers::push_fixed`,
//! which every G-code word goes through); CSV columns with exactly `N` decimals, returning
//! the value as printed so the report measures the rows a reader parses (the setpoint
//! writer's `put`, two digits at a time: it is the writing thread of a large plan). Both
//! scale by [`POW10_U64`] and round half away from zero. The report's SVG coordinates
//! (0.1 px) use `format!`.

/// Powers of ten `10^0 ..= 10^15` as integers: every fixed-point scale either writer uses
/// (and, converted to `f64`, exactly the same powers as floating-point scales).
pub const POW10_U64: [u64; 16] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
    10_000_000_000,
    100_000_000_000,
    1_000_000_000_000,
    10_000_000_000_000,
    100_000_000_000_000,
    1_000_000_000_000_000,
];
