//! Smooths a G-code file of any size block by block, in memory that does not grow with
//! the program: [`BlockReader`] interprets the file a batch at a time, [`StreamSmoother`]
//! smooths each chain of feed moves as it completes (cutting chains longer than the
//! window), and every window handed out is measured both ways against its own programmed
//! moves. Prints what it did and the peak resident memory.
//!
//! ```text
//! cargo run --release -p ncsmooth-gcode --example stream_smooth -- FILE [METHOD] [TOL_MM] [WINDOW_MOVES]
//! ```
//! METHOD is one of none, bspline, arc, nurbs, trig (default bspline); TOL_MM defaults to
//! 0.01; WINDOW_MOVES to [`WINDOW_MOVES`]. Exits 1 when a window exceeds the tolerance,
//! 2 on bad input. `NOVERIFY=1` skips the measurement.
//!
//! linuxcnc_stellabee1 (3.2 MB, 169 k moves), bspline at 0.01 mm: 45 MB peak with a
//! window of 1024 moves (243 MB with 8192: measuring a window of curves costs about 10 kB
//! per output curve), 45 MB without the measurement; `none` 24 MB.

use ncsmooth::smooth::{Method, SmoothOptions};
use ncsmooth::{Block, StreamOptions, StreamSmoother};
use ncsmooth_gcode::{BlockReader, ParseOptions};
use std::time::Instant;

/// Default window (moves): a chain longer than this is cut (see [`StreamSmoother`]).
const WINDOW_MOVES: usize = 1024;
/// Blocks asked of the reader at a time.
const BATCH_BLOCKS: usize = 4096;
/// Accuracy (mm) of the per-window measurement.
const MEASURE_ACCURACY_MM: f64 = 1e-4;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: stream_smooth FILE [METHOD] [TOL_MM] [WINDOW_MOVES]");
        std::process::exit(2);
    };
    let name = args.get(2).map_or("bspline", String::as_str);
    let method =
        Method::from_name(name).unwrap_or_else(|| exit_bad(&format!("unknown method {name}")));
    let tol_mm: f64 = args
        .get(3)
        .map_or(Ok(0.01), |t| t.parse())
        .unwrap_or_else(|_| exit_bad("bad TOL_MM"));
    let mut stream = StreamOptions::default();
    stream.window_moves = match args.get(4) {
        Some(w) => w.parse().unwrap_or_else(|_| exit_bad("bad WINDOW_MOVES")),
        None => WINDOW_MOVES,
    };
    stream.verify_accuracy_mm = std::env::var_os("NOVERIFY")
        .is_none()
        .then_some(MEASURE_ACCURACY_MM);
    let opts = SmoothOptions::default()
        .with_method(method)
        .with_tol_mm(tol_mm);

    let clock = Instant::now();
    let popts = ParseOptions::default();
    let mut reader =
        BlockReader::open(path.as_ref(), path, &popts).unwrap_or_else(|e| exit_bad(&e.to_string()));
    let mut smoother =
        StreamSmoother::new(opts, stream).unwrap_or_else(|e| exit_bad(&e.to_string()));
    let (mut batch, mut out) = (Vec::new(), Vec::new());
    let (mut moves_in, mut moves_out) = (0usize, 0usize);
    loop {
        let more = reader
            .read_blocks(&mut batch, BATCH_BLOCKS)
            .unwrap_or_else(|e| exit_bad(&e.to_string()));
        for b in batch.drain(..) {
            moves_in += usize::from(matches!(b, Block::Move(_)));
            smoother.push(b, &mut out);
        }
        if !more {
            smoother.finish(&mut out);
        }
        // A real consumer would plan or write these now; here they are counted and dropped.
        moves_out += out.iter().filter(|b| matches!(b, Block::Move(_))).count();
        out.clear();
        if !more {
            break;
        }
    }
    let check = smoother.window_check();
    let r = smoother.report();
    println!(
        "{path}: {moves_in} moves in, {moves_out} out, {} chains, {} runs fitted",
        r.chains, r.runs_fitted
    );
    match check.worst {
        Some((a, b, line)) => println!(
            "{} windows measured: worst {a:.6} mm output to program, {b:.6} mm vertex to output (line {line}), tol {tol_mm} mm",
            check.windows
        ),
        None => println!("no feed moves"),
    }
    println!(
        "{:.2} s, peak resident memory {}",
        clock.elapsed().as_secs_f64(),
        peak_rss().map_or("unknown".to_string(), |kb| format!(
            "{:.1} MB",
            kb as f64 / 1024.0
        ))
    );
    if !check.within(tol_mm) {
        std::process::exit(1);
    }
}

fn exit_bad(msg: &str) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(2);
}

/// Peak resident set size (kB) of this process, where the system tells it (Linux).
fn peak_rss() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}
