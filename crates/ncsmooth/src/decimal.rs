//! Shared pieces of the fixed-point decimal formatting of the setpoint CSV
//! ([`crate::interp::SetpointWriter`]) and the G-code writer (`ncsmooth-gcode`).

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
