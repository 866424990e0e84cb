//! Plans a G-code file into setpoints: the library's `ncsmooth plan FILE --method bspline
//! --feed F --acc A --setpoints OUT` (B-splines within 0.01 mm, 1 ms period), read,
//! smoothed and planned a part at a time, the CSV byte for byte the same.
//!
//! ```text
//! cargo run --release -p ncsmooth-gcode --example plan_file -- part.ngc 50 500 part.csv
//! ```

use ncsmooth::feed::PlanOptions;
use ncsmooth::interp::SetpointWriter;
use ncsmooth::Method;
use ncsmooth_gcode::{PlanInput, PlanJob, PlanRunReport};
use std::error::Error;
use std::io::{BufWriter, Write};

/// Plans the file at `path` at `feed_mm_s` and `acc_mm_s2` into `out` as setpoint CSV.
pub fn plan_file(
    path: &str,
    feed_mm_s: f64,
    acc_mm_s2: f64,
    out: impl Write + Send,
) -> Result<PlanRunReport, Box<dyn Error>> {
    let limits = PlanOptions::default()
        .with_feed_mm_s(feed_mm_s)
        .with_acc_mm_s2([acc_mm_s2; 3]);
    let job = PlanJob::new(Method::Bspline, 0.01).with_plan_options(limits);
    let input = PlanInput::File {
        name: path,
        path: path.as_ref(),
    };
    let done = job.run(&input, SetpointWriter::new(BufWriter::new(out)), &|_| false)?;
    done.sink.into_inner()?.flush()?; // every limit held, measured on the rows, or an error
    Ok(done.run)
}

#[allow(dead_code)] // a test includes this file for `plan_file`
fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, feed, acc, output] = &args[..] else {
        return Err("usage: plan_file INPUT FEED_MM_S ACC_MM_S2 OUTPUT.csv".into());
    };
    let file = std::fs::File::create(output)?;
    let run = plan_file(input, feed.parse()?, acc.parse()?, file)?;
    eprintln!(
        "{input}: cycle {:.3} s, {} setpoints written to {output}",
        run.plan.cycle_time_s, run.plan.setpoints
    );
    Ok(())
}
