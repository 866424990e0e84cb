//! Conformance with LinuxCNC's own interpreter: the programs of LinuxCNC's interpreter test
//! suite (`../shared/data/linuxcnc-interp-tests`, see its SOURCES.md), run through
//! ncsmooth's interpreter on a known machine (LinuxCNC's standalone `rs274`: zero offsets,
//! machine zero, the test's tool table), compared with the canonical output the suite
//! expects: the same motion (end points and arc centres within 1e-4 in the test's units)
//! and the same comments, messages and `(PRINT,...)` lines, in order. Programs the suite
//! expects LinuxCNC to refuse must be refused.
//!
//! Tests outside ncsmooth's scope are listed in [`OUT_OF_SCOPE`] with the reason; tests
//! that run several programs are described in [`MULTI`], with the reason for any program
//! not compared. The data is GPL test data read in place; when it is absent the tests print
//! a message and pass.

use ncsmooth_gcode::{parse_bytes, Canon, MachineModel, ParseOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn suite_dir() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/linuxcnc-interp-tests");
    if d.is_dir() {
        Some(d)
    } else {
        println!(
            "SKIP: LinuxCNC interpreter tests not found at {}",
            d.display()
        );
        None
    }
}

/// Tests ncsmooth does not run, and why.
const OUT_OF_SCOPE: &[(&str, &str)] = &[
    (
        "abort-hot-comment",
        "needs an INI file and LinuxCNC's task (hot comments)",
    ),
    (
        "cam-nisley",
        "cutter radius compensation (G41/G42), refused by ncsmooth",
    ),
    (
        "compile",
        "compiles a C++ program against LinuxCNC's library",
    ),
    (
        "crazy-paths",
        "cutter radius compensation (G41/G42), refused by ncsmooth",
    ),
    (
        "g33.1",
        "rigid tapping (spindle-synchronised motion), refused by ncsmooth",
    ),
    (
        "g52/g92-offset-persistence",
        "persistent G92 offsets across runs (INI and var file)",
    ),
    (
        "g64-r-planner",
        "G64 R (planner selection) is LinuxCNC 2.10 (master); 2.9, up to 2.9.9 and the \
         installed rs274, refuses it (\"R word with no g code that uses it\"), as ncsmooth \
         does; the expected SET_PLANNER_MODE output is not modelled",
    ),
    (
        "g71-endless-loop",
        "lathe roughing cycle G71, refused by ncsmooth",
    ),
    (
        "g71-endless-loop2",
        "lathe roughing cycle G71, refused by ncsmooth",
    ),
    (
        "g71-endless-loop_2",
        "lathe roughing cycle G71, refused by ncsmooth",
    ),
    ("g71-with-g70", "lathe cycles G70/G71, refused by ncsmooth"),
    ("g72-facing", "lathe facing cycle G72, refused by ncsmooth"),
    (
        "g72-missing-iteration",
        "lathe facing cycle G72, refused by ncsmooth",
    ),
    ("g76", "lathe threading cycle G76, refused by ncsmooth"),
    ("iniparam", "INI-file parameters"),
    ("iniparam-failassign", "INI-file parameters"),
    (
        "inside-corners",
        "cutter radius compensation (G41/G42), refused by ncsmooth",
    ),
    (
        "inverse-time-with-comp",
        "inverse-time feed (G93) with cutter compensation, refused",
    ),
    ("m19", "spindle orientation configured from an INI file"),
    ("mdi-oword-m66", "runs a full LinuxCNC with a UI script"),
    (
        "nested-sub-error",
        "subroutines in separate files (INI subroutine path)",
    ),
    (
        "nested-sub-in-file-error",
        "subroutines in separate files (INI subroutine path)",
    ),
    (
        "oword-mdi-sub-update",
        "runs a full LinuxCNC with a UI script",
    ),
    (
        "oword-unwind",
        "subroutines in separate files (INI subroutine path)",
    ),
    ("plug/absolute", "interpreter plug-ins"),
    ("plug/filename", "interpreter plug-ins"),
    ("plug/relative", "interpreter plug-ins"),
    ("pymove", "Python remapping"),
    ("python", "Python remapping"),
    ("python-self", "Python remapping"),
    ("sequence-number", "needs an INI file (remapped codes)"),
    (
        "sub-call-from-sub",
        "subroutines in separate files (INI subroutine path)",
    ),
    ("subroutine-return", "runs a full LinuxCNC with a UI script"),
    ("value-returned", "Python remapping"),
];

/// What LinuxCNC does with one program of a test, and what ncsmooth must do.
#[derive(Clone, Copy, Debug)]
enum Outcome {
    /// Runs: the same canonical output.
    Runs,
    /// Refused, by both.
    Refused,
    /// LinuxCNC refuses it at its end, for the reason given, which ncsmooth deliberately
    /// does not share: ncsmooth runs it, with the canonical output LinuxCNC gives up to
    /// there.
    RunsDespite(&'static str),
    /// Not compared, for the reason given.
    NotRun(&'static str),
}

/// Tests that run more than one program: each program, in the order of its output in
/// `expected`, with what happens to it.
const MULTI: &[(&str, &[(&str, Outcome)])] = &[
    (
        "m98m99/06-error-mixed-sub-styles",
        &[
            ("O...-called-with-O..._call.ngc", Outcome::Refused),
            ("O...-ended-with-O..._endsub.ngc", Outcome::Refused),
            ("O...-sub-called-with-M98.ngc", Outcome::Refused),
            ("O...-sub-ended-with-M99.ngc", Outcome::Refused),
        ],
    ),
    (
        "m98m99/09-disable-fanuc-subs",
        &[
            // test-fanuc.ini sets DISABLE_FANUC_STYLE_SUB = 0, the default.
            ("test-fanuc.ngc", Outcome::Runs),
            ("test-rs274ngc.ngc", Outcome::Runs),
            (
                "test-fanuc.ngc",
                Outcome::NotRun(
                    "needs INI [RS274NGC] DISABLE_FANUC_STYLE_SUB = 1; ncsmooth reads \
                     LinuxCNC's default (Fanuc-style subprograms enabled) and has no such switch",
                ),
            ),
            ("test-rs274ngc.ngc", Outcome::Runs),
            ("test-fanuc.ngc", Outcome::Runs),
            ("test-rs274ngc.ngc", Outcome::Runs),
        ],
    ),
    (
        "m98m99/11-main-program-oword",
        &[
            ("test-legal-end-main-with-m2.ngc", Outcome::Runs),
            ("test-legal-end-main-with-m02.ngc", Outcome::Runs),
            ("test-legal-end-main-with-m30.ngc", Outcome::Runs),
            ("test-legal-end-main-with-percent.ngc", Outcome::Runs),
            (
                "test-illegal-end-main-with-eof.ngc",
                Outcome::RunsDespite(
                    "LinuxCNC refuses a file that ends without M2, M30 or a closing %; \
                     ncsmooth reads such files (most CAM and grbl files end so)",
                ),
            ),
            ("test-illegal-no-m30-before-osub.ngc", Outcome::Refused),
            ("test-illegal-sub-after-percent.ngc", Outcome::Refused),
        ],
    ),
    (
        "m98m99/13-named-program",
        &[
            ("test-named.ngc", Outcome::Runs),
            ("test-numbered.ngc", Outcome::Runs),
        ],
    ),
];

/// Parts of in-scope tests that are not compared, and why.
const PARTLY_OUT_OF_SCOPE: &[(&str, &str)] = &[(
    "m98m99/12-M99-endless-main-program",
    "its run in LinuxCNC's task (motion-logger: M99 restarts the main program, three \
     passes) is not compared; ncsmooth reads M99 in the main program as rs274 does (one \
     pass) and writes such a program as programmed",
)];

/// One comparable canonical command.
#[derive(Clone, Debug, PartialEq)]
enum Cmd {
    Move(&'static str, Vec<f64>),
    Text(&'static str, String),
}

/// Whether `line` is a canonical command (`[number] N..... NAME(...)`, the `N` field being
/// dots or the block's line number) rather than something the program printed.
fn is_canon_line(line: &str) -> bool {
    let mut t = line.split_whitespace().peekable();
    if t.peek()
        .is_some_and(|w| w.bytes().all(|b| b.is_ascii_digit()))
    {
        t.next();
    }
    let n_field = t.next().is_some_and(|w| {
        w.len() > 1 && w.starts_with('N') && w[1..].bytes().all(|b| b == b'.' || b.is_ascii_digit())
    });
    let name = t
        .next()
        .and_then(|w| w.split_once('('))
        .is_some_and(|(n, _)| {
            !n.is_empty()
                && n.bytes()
                    .all(|b| b.is_ascii_uppercase() || b == b'_' || b.is_ascii_digit())
        });
    n_field && name
}

/// The output of each `rs274` run in `text`: a run starts with the interpreter's
/// initialisation (`USE_LENGTH_UNITS` directly followed by `SET_G5X_OFFSET`) and ends at
/// its last canonical command (what follows belongs to the harness: headers, the next
/// run's `executing`).
fn runs_of(text: &str) -> Vec<Vec<&str>> {
    let mut runs: Vec<Vec<&str>> = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    for (i, &line) in lines.iter().enumerate() {
        let starts = line.contains("USE_LENGTH_UNITS(")
            && lines
                .get(i + 1)
                .is_some_and(|l| l.contains("SET_G5X_OFFSET("));
        if starts {
            runs.push(Vec::new());
        }
        if let Some(r) = runs.last_mut() {
            r.push(line);
        }
    }
    for r in &mut runs {
        while r.last().is_some_and(|l| !is_canon_line(l)) {
            r.pop();
        }
    }
    runs
}

/// Parses one run of LinuxCNC's canonical output into the commands compared: motion (end
/// points in X Y Z order whatever the plane, arc centres), comments (not the interpreter's
/// own), messages, and the lines the program printed (`(PRINT,...)`).
fn expected_cmds(lines: &[&str]) -> Vec<Cmd> {
    let mut plane = "XY";
    let mut out = Vec::new();
    for &line in lines {
        if !is_canon_line(line) {
            let t = squeeze(line);
            if !t.is_empty() && t != "executing" {
                out.push(Cmd::Text("print", t));
            }
            continue;
        }
        let Some(open) = line.find('(') else { continue };
        let name = line[..open].split_whitespace().last().unwrap_or("");
        let args = line[open + 1..line.rfind(')').unwrap_or(line.len())].to_string();
        let nums = || -> Vec<f64> {
            args.split(',')
                .filter_map(|a| a.trim().parse::<f64>().ok())
                .collect()
        };
        match name {
            "SELECT_PLANE" => {
                plane = if args.contains("XZ") {
                    "XZ"
                } else if args.contains("YZ") {
                    "YZ"
                } else {
                    "XY"
                }
            }
            "STRAIGHT_TRAVERSE" => out.push(Cmd::Move("traverse", nums()[..3].to_vec())),
            "STRAIGHT_FEED" => out.push(Cmd::Move("feed", nums()[..3].to_vec())),
            "ARC_FEED" => {
                let n = nums();
                // (first_end, second_end, first_centre, second_centre, rotation, axis_end)
                let (e1, e2, c1, c2, axis) = (n[0], n[1], n[2], n[3], n[5]);
                let end = match plane {
                    "XY" => vec![e1, e2, axis],
                    "XZ" => vec![e2, axis, e1],
                    _ => vec![axis, e1, e2],
                };
                out.push(Cmd::Move("arc", [end, vec![c1, c2, n[4]]].concat()));
            }
            "COMMENT" => {
                let t = args.trim().trim_matches('"').to_string();
                if !t.starts_with("interpreter:") {
                    out.push(Cmd::Text("comment", t));
                }
            }
            "MESSAGE" => out.push(Cmd::Text(
                "message",
                args.trim().trim_matches('"').to_string(),
            )),
            _ => {}
        }
    }
    out
}

/// Our canonical commands; `awk`: the test pipes `rs274` through `awk '{$1=""; print}'`,
/// which drops the first word of every printed line.
fn our_cmds(canon: &[Canon], awk: bool) -> Vec<Cmd> {
    canon
        .iter()
        .filter_map(|c| match c {
            Canon::Traverse { end } => Some(Cmd::Move("traverse", end[..3].to_vec())),
            Canon::Feed { end } => Some(Cmd::Move("feed", end[..3].to_vec())),
            Canon::Arc { end, center, turn } => Some(Cmd::Move(
                "arc",
                vec![
                    end[0],
                    end[1],
                    end[2],
                    center[0],
                    center[1],
                    f64::from(*turn),
                ],
            )),
            Canon::Comment(t) => Some(Cmd::Text("comment", t.clone())),
            Canon::Message(t) => Some(Cmd::Text("message", t.clone())),
            Canon::Print(t) => {
                let words = t.split_whitespace().skip(usize::from(awk));
                Some(Cmd::Text("print", words.collect::<Vec<_>>().join(" ")))
            }
            _ => None,
        })
        .collect()
}

/// A tool table of LinuxCNC's format (`T1 P1 Z0.511 D0.125 ;comment`), in inches (the
/// standalone interpreter's machine units), as mm offsets.
fn tool_table(path: &Path) -> HashMap<u32, [f64; 9]> {
    let mut t = HashMap::new();
    let Ok(text) = std::fs::read_to_string(path) else {
        return t;
    };
    for line in text.lines() {
        let line = line.split(';').next().unwrap_or("");
        let mut n = None;
        let mut off = [0.0; 9];
        for w in line.split_whitespace() {
            let (l, v) = w.split_at(1);
            let Ok(v) = v.parse::<f64>() else { continue };
            match l.to_ascii_uppercase().as_str() {
                "T" => n = Some(v as u32),
                "X" => off[0] = v * 25.4,
                "Y" => off[1] = v * 25.4,
                "Z" => off[2] = v * 25.4,
                _ => {}
            }
        }
        if let Some(n) = n {
            t.insert(n, off);
        }
    }
    t
}

/// How a test runs `rs274`.
struct Invocation {
    /// With the test's tool table (`-t`).
    tools: bool,
    /// Through `awk '{$1=""; print}'`.
    awk: bool,
    /// Only the messages are kept (`grep MESSAGE`).
    only_messages: bool,
}

/// What running test `rel` (directory `dir`) gave: `Ok(())`, or why it failed.
fn run_test(rel: &str, dir: &Path) -> Result<(), String> {
    let sh = std::fs::read_to_string(dir.join("test.sh")).map_err(|e| e.to_string())?;
    let line = sh
        .lines()
        .find(|l| l.contains("rs274") && l.contains("-g"))
        .ok_or("no rs274 command")?;
    let how = Invocation {
        tools: line.split_whitespace().any(|w| w == "-t"),
        awk: sh.contains(r#"awk '{$1=""; print}'"#),
        only_messages: line.contains("/MESSAGE/"),
    };
    let expected = std::fs::read_to_string(dir.join("expected")).map_err(|e| e.to_string())?;
    let runs = runs_of(&expected);
    if let Some((_, programs)) = MULTI.iter().find(|(t, _)| *t == rel) {
        if runs.len() != programs.len() {
            return Err(format!(
                "{} runs in expected, {} programs listed",
                runs.len(),
                programs.len()
            ));
        }
        for ((prog, outcome), run) in programs.iter().zip(&runs) {
            if let Outcome::NotRun(why) = outcome {
                println!("  not compared: {rel}/{prog}: {why}");
                continue;
            }
            run_program(dir, prog, *outcome, run, &how).map_err(|e| format!("{prog}: {e}"))?;
        }
        return Ok(());
    }
    let prog = line
        .split_whitespace()
        .find(|w| w.ends_with(".ngc"))
        .ok_or("no program")?;
    let must_fail = sh.contains("! rs274") || sh.contains("if ! rs274");
    let outcome = if must_fail {
        Outcome::Refused
    } else {
        Outcome::Runs
    };
    let all: Vec<&str> = expected.lines().collect();
    run_program(dir, prog, outcome, &all, &how)
}

/// Runs program `prog` of test directory `dir` and compares it with `run`, its part of the
/// expected output.
fn run_program(
    dir: &Path,
    prog: &str,
    outcome: Outcome,
    run: &[&str],
    how: &Invocation,
) -> Result<(), String> {
    let mut machine = MachineModel {
        machine_units: ncsmooth::Units::Inches,
        ..Default::default()
    };
    if how.tools {
        machine.tools = tool_table(&dir.join("test.tbl"));
    }
    let src = std::fs::read(dir.join(prog)).map_err(|e| e.to_string())?;
    let mut opts = ParseOptions::with_machine(machine);
    opts.canon = true;
    let refused = matches!(outcome, Outcome::Refused);
    let p = match parse_bytes(&src, prog, &opts) {
        Ok(p) => p,
        Err(_) if refused => return Ok(()),
        Err(e) => return Err(format!("refused: {e}")),
    };
    if refused {
        return Err("accepted a program LinuxCNC refuses".into());
    }
    if let Outcome::RunsDespite(why) = outcome {
        let test = dir.file_name().unwrap_or_default().to_string_lossy();
        println!("  runs, refused by LinuxCNC: {test}/{prog}: {why}");
    }
    let mut want = expected_cmds(run);
    let mut got = our_cmds(&p.canon, how.awk);
    if how.only_messages {
        want.retain(|c| matches!(c, Cmd::Text("message", _)));
        got.retain(|c| matches!(c, Cmd::Text("message", _)));
    }
    compare(&want, &got)
}

fn squeeze(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn compare(want: &[Cmd], got: &[Cmd]) -> Result<(), String> {
    for (i, (w, g)) in want.iter().zip(got).enumerate() {
        let same = match (w, g) {
            (Cmd::Move(a, x), Cmd::Move(b, y)) => {
                a == b
                    && x.len() == y.len()
                    && x.iter().zip(y).all(|(u, v)| (u - v).abs() <= 1.5e-4)
            }
            // The suite's `awk` collapses runs of blanks in what it records.
            (Cmd::Text(a, x), Cmd::Text(b, y)) => a == b && squeeze(x) == squeeze(y),
            _ => false,
        };
        if !same {
            return Err(format!("command {i}: expected {w:?}, got {g:?}"));
        }
    }
    if want.len() != got.len() {
        return Err(format!(
            "{} commands expected, {} made (next expected {:?}, next made {:?})",
            want.len(),
            got.len(),
            want.get(got.len()),
            got.get(want.len())
        ));
    }
    Ok(())
}

/// Every test directory (holding `test.sh`), relative to the suite.
fn test_dirs(root: &Path) -> Vec<String> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<String>) {
        let Ok(rd) = std::fs::read_dir(d) else { return };
        let mut entries: Vec<_> = rd.flatten().map(|e| e.path()).collect();
        entries.sort();
        if entries
            .iter()
            .any(|p| p.file_name().is_some_and(|n| n == "test.sh"))
        {
            let rel = d.strip_prefix(root).unwrap().display().to_string();
            out.push(rel);
            return;
        }
        for p in entries {
            if p.is_dir() {
                walk(root, &p, out);
            }
        }
    }
    let mut v = Vec::new();
    walk(root, root, &mut v);
    v
}

fn out_of_scope(rel: &str) -> Option<&'static str> {
    OUT_OF_SCOPE
        .iter()
        .find(|(t, _)| rel == *t || rel.starts_with(&format!("{t}/")))
        .map(|(_, why)| *why)
}

#[test]
fn linuxcnc_interpreter_suite() {
    let Some(root) = suite_dir() else { return };
    let (mut pass, mut fail) = (Vec::new(), Vec::new());
    let mut skipped = 0;
    for rel in test_dirs(&root) {
        if rel == "bad" || rel == "good" {
            continue;
        }
        if let Some(why) = out_of_scope(&rel) {
            println!("out of scope: {rel}: {why}");
            skipped += 1;
            continue;
        }
        if let Some((_, why)) = PARTLY_OUT_OF_SCOPE.iter().find(|(t, _)| *t == rel) {
            println!("  partly out of scope: {rel}: {why}");
        }
        match run_test(&rel, &root.join(&rel)) {
            Ok(()) => pass.push(rel),
            Err(e) => fail.push(format!("{rel}: {e}")),
        }
    }
    println!(
        "in scope: {} passed of {}; {skipped} out of scope",
        pass.len(),
        pass.len() + fail.len()
    );
    for f in &fail {
        println!("FAIL {f}");
    }
    assert!(
        fail.is_empty(),
        "{} conformance failures:\n{}",
        fail.len(),
        fail.join("\n")
    );
}

/// LinuxCNC's `bad/` programs: each must be refused (ncsmooth refuses cutter compensation
/// and a few other constructs for its own reasons too).
#[test]
fn linuxcnc_bad_programs_are_refused() {
    let Some(root) = suite_dir() else { return };
    let mut n = 0;
    for e in std::fs::read_dir(root.join("bad")).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_none_or(|x| x != "ngc") {
            continue;
        }
        let src = std::fs::read(&p).unwrap();
        let opts = ParseOptions::with_machine(MachineModel::default());
        let r = parse_bytes(&src, &p.display().to_string(), &opts);
        assert!(r.is_err(), "{} was accepted", p.display());
        n += 1;
    }
    assert!(n >= 20, "only {n} bad programs");
}

/// LinuxCNC's `good/` arcs (at the edge of its radius tolerance) are accepted, with its
/// canonical output.
#[test]
fn linuxcnc_good_arcs_are_accepted() {
    let Some(root) = suite_dir() else { return };
    let mut n = 0;
    for e in std::fs::read_dir(root.join("good")).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_none_or(|x| x != "ngc") {
            continue;
        }
        let src = std::fs::read(&p).unwrap();
        let mut opts = ParseOptions::with_machine(MachineModel::default());
        opts.canon = true;
        let prog =
            parse_bytes(&src, &p.display().to_string(), &opts).unwrap_or_else(|e| panic!("{e}"));
        let expected = std::fs::read_to_string(p.with_extension("ngc.expected")).unwrap();
        let lines: Vec<&str> = expected.lines().collect();
        if let Err(e) = compare(&expected_cmds(&lines), &our_cmds(&prog.canon, false)) {
            panic!("{}: {e}", p.display());
        }
        n += 1;
    }
    assert_eq!(n, 6);
}
