//! Smooths a G-code file for a controller, verifies it and writes it: the library's
//! `ncsmooth smooth FILE --dialect D -o OUT` (B-splines within 0.01 mm), byte for byte.
//!
//! ```text
//! cargo run --release -p ncsmooth-gcode --example smooth_file -- part.ngc grbl part_grbl.ngc
//! ```

use ncsmooth::Method;
use ncsmooth_gcode::{Dialect, SmoothJob};
use std::error::Error;

/// The verified G-code of the file at `path` (named so in its header and errors),
/// smoothed with B-spline corners within 0.01 mm for `dialect`.
pub fn smooth_file(path: &str, dialect: Dialect) -> Result<Vec<u8>, Box<dyn Error>> {
    let src = std::fs::read(path)?;
    let job = SmoothJob::new(Method::Bspline, 0.01).with_dialect(dialect);
    let done = job.run_bytes(path, &src)?;
    done.verified()?; // within 0.01 mm both ways as read back, LinuxCNC's blending included
    Ok(done.gcode)
}

#[allow(dead_code)] // a test includes this file for `smooth_file`
fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, dialect, output] = &args[..] else {
        return Err(
            "usage: smooth_file INPUT DIALECT OUTPUT (DIALECT: linuxcnc, grbl, ...)".into(),
        );
    };
    let dialect = Dialect::ALL
        .into_iter()
        .find(|d| d.name() == dialect)
        .ok_or_else(|| format!("unknown dialect {dialect}"))?;
    let gcode = smooth_file(input, dialect)?;
    std::fs::write(output, &gcode)?;
    eprintln!("{input}: {} bytes written to {output}", gcode.len());
    Ok(())
}
