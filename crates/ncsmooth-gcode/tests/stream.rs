//! [`BlockReader`] reads a file block by block and gives what [`parse_bytes`] gives: the
//! same blocks in order, the same counts, extra axes, units and start, and the same first
//! error, whatever the batch size; and it hands blocks out as it goes instead of holding
//! the program.

use ncsmooth::path::Block;
use ncsmooth_gcode::flags;
use ncsmooth_gcode::{parse_bytes, BlockReader, MachineModel, ParseError, ParseOptions};
use std::path::{Path, PathBuf};

/// Batch sizes tried: one block at a time, an odd size, a large one.
const BATCHES: [usize; 3] = [1, 7, 4096];

fn shared_programs() -> Vec<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    if !root.is_dir() {
        println!(
            "SKIP: {} not found: shared programs not streamed",
            root.display()
        );
        return Vec::new();
    }
    let mut out = Vec::new();
    walk(&root, &mut out);
    out.sort();
    out
}

fn walk(d: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(d).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(&p, out);
        } else if p
            .extension()
            .is_some_and(|x| ["ngc", "nc", "gcode"].contains(&&*x.to_string_lossy()))
        {
            out.push(p);
        }
    }
}

/// What a streamed read gives: the blocks, then the reader's end state or its error.
struct Streamed {
    blocks: Vec<Block>,
    end: Result<(ncsmooth_gcode::ParseStats, u8, ncsmooth::Units, usize), ParseError>,
    largest_batch: usize,
}

fn stream(path: &Path, opts: &ParseOptions, batch: usize) -> Streamed {
    let name = path.display().to_string();
    let mut blocks = Vec::new();
    let mut largest_batch = 0;
    let end = (|| {
        let mut r = BlockReader::open(path, &name, opts)?;
        loop {
            let before = blocks.len();
            let more = r.read_blocks(&mut blocks, batch)?;
            largest_batch = largest_batch.max(blocks.len() - before);
            if !more {
                break;
            }
        }
        Ok((
            r.stats().clone(),
            r.extra_axes_mask(),
            r.units(),
            r.warnings_dropped(),
        ))
    })();
    Streamed {
        blocks,
        end,
        largest_batch,
    }
}

fn check_same(path: &Path, opts: &ParseOptions) {
    let bytes = std::fs::read(path).unwrap();
    let name = path.display().to_string();
    let whole = parse_bytes(&bytes, &name, opts);
    for batch in BATCHES {
        let s = stream(path, opts, batch);
        match (&whole, &s.end) {
            (Ok(p), Ok((stats, mask, units, dropped))) => {
                assert_eq!(
                    p.toolpath.blocks.len(),
                    s.blocks.len(),
                    "{name} batch {batch}"
                );
                for (k, (a, b)) in p.toolpath.blocks.iter().zip(&s.blocks).enumerate() {
                    assert_eq!(a, b, "{name} batch {batch}: block {k}");
                }
                assert_eq!(p.toolpath.extra_axes_mask, *mask, "{name}");
                assert_eq!(p.toolpath.units, *units, "{name}");
                // The counts kept as the program is read are those of its source map.
                let lines = &p.source.lines;
                let replaceable = lines.iter().filter(|l| l.has(flags::REPLACEABLE)).count();
                assert_eq!(p.stats.replaceable_lines, replaceable, "{name}");
                let known = lines.iter().fold(0u16, |m, l| m | l.state.known);
                assert_eq!(p.stats.axes_known, known, "{name}");
                let mut want = p.stats.clone();
                assert_eq!(
                    want.warnings.len(),
                    stats.warnings.len() + dropped,
                    "{name}"
                );
                want.warnings.truncate(stats.warnings.len());
                assert_eq!(&want, stats, "{name}");
            }
            (Err(e), Err(f)) => {
                assert_eq!(e, f, "{name} batch {batch}");
                // What came before the error is what the whole parse would have given.
            }
            (w, s) => panic!(
                "{name} batch {batch}: whole {:?} but streamed {:?}",
                w.as_ref().map(|_| "ok"),
                s.as_ref().map(|_| "ok")
            ),
        }
    }
}

#[test]
fn shared_programs_stream_as_they_parse() {
    let files = shared_programs();
    for f in &files {
        check_same(f, &ParseOptions::default());
        check_same(f, &ParseOptions::with_machine(MachineModel::default()));
    }
    println!("{} programs streamed", files.len());
}

fn write_tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ncsmooth-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Control flow that jumps back and forth (loops, calls to subroutines defined after the
/// main program, Fanuc subprograms, conditionals), G5 splines whose P Q a later G5 reuses,
/// extra axes that appear late, a main program ended by M99, and errors found late.
#[test]
fn jumps_pins_extra_axes_and_errors_stream_as_they_parse() {
    let opts = ParseOptions::default();
    let mut lines = String::from("G21 G90 G17\nG0 X0 Y0 Z1\nG1 Z0 F600\n#1 = 0\n");
    lines += "o10 while [#1 LT 3]\n  G1 X[#1 * 2] Y1\n  o20 if [#1 EQ 1]\n    G1 Y2\n  o20 else\n    o100 call [#1]\n  o20 endif\n  #1 = [#1 + 1]\no10 endwhile\n";
    for k in 0..300 {
        lines += &format!(
            "G1 X{:.3} Y{:.3}\n",
            f64::from(k) * 0.1,
            (f64::from(k) * 0.1).sin()
        );
    }
    lines += "G5 I1 J0 P-1 Q0 X40 Y0\nG5 P-1 Q1 X41 Y1\nG1 X42\nM98 P200 L2\nG1 A10 X43\n";
    lines += "M2\no100 sub\n  G1 Z-[#1]\n  G1 Z0\no100 endsub\nO200\nG91 G1 X0.5\nG90\nM99\n";
    let p = write_tmp("flow.ngc", &lines);
    check_same(&p, &opts);
    // A main program ended by M99: every move pinned, known from the start.
    let p = write_tmp("m99.ngc", "G0 X0 Y0\nG1 X1 F100\nG1 X2 Y1\nG1 X3\nM99\n");
    check_same(&p, &opts);
    // Errors after blocks were handed out: an unclosed comment far down, a loop never
    // closed, a call to a subroutine that is not there, bytes that are not text.
    let mut body = String::from("G0 X0 Y0\nG1 F100\n");
    for k in 0..50 {
        body += &format!("G1 X{k}\n");
    }
    for (name, tail) in [
        ("comment.ngc", "G1 X1 (never closed\nM2\n"),
        ("loop.ngc", "o5 while [1]\nG1 X2\n"),
        ("call.ngc", "o7 call\nM2\n"),
    ] {
        check_same(&write_tmp(name, &format!("{body}{tail}")), &opts);
    }
    let mut bad = body.clone().into_bytes();
    bad.extend_from_slice(b"G1 X\xff2\nM2\n");
    let p = write_tmp("utf8.ngc", "");
    std::fs::write(&p, &bad).unwrap();
    check_same(&p, &opts);
}

/// Blocks are handed out as they are made: with a batch of 64 on a program of 20000
/// moves, no call gives much more than its batch (a line makes a few blocks at most), so
/// the reader holds a batch, not the program.
#[test]
fn blocks_are_handed_out_as_they_are_made() {
    let mut text = String::from("G21 G90\nG0 X0 Y0 Z0\nG1 F3000\n");
    for k in 0..20_000 {
        let a = f64::from(k) * 0.01;
        text += &format!(
            "G1 X{:.4} Y{:.4}\n",
            a.cos() * (1.0 + a),
            a.sin() * (1.0 + a)
        );
    }
    text += "M2\n";
    let p = write_tmp("spiral.ngc", &text);
    let s = stream(&p, &ParseOptions::default(), 64);
    assert!(s.end.is_ok());
    let whole = parse_bytes(text.as_bytes(), "spiral.ngc", &ParseOptions::default()).unwrap();
    assert_eq!(s.blocks, whole.toolpath.blocks);
    assert!(s.largest_batch <= 64 + 2, "{}", s.largest_batch);
}
