//! `compare` on every file of `../shared/data/gcode` (or `$NCSMOOTH_SHARED_DATA/gcode`):
//! it succeeds, its page stays under [`MAX_PAGE_BYTES`], and for each method its JSON
//! (`methods[i].plan`) agrees with what `plan --method M --report` gives: every field but
//! the timings, exactly. Skips with a message when the data is absent. Ignored in debug
//! builds (minutes); CI runs it in release (`cargo test --release -- --ignored`).
//!
//! Programs over [`MAX_PROGRAM_BYTES`] are left out (named in the output): `compare` and
//! `plan` run the same library jobs whatever the size (`CompareJob`, `PlanJob`), and the
//! large file's smoothed G-code and its library equivalence are pinned by `golden.rs` and
//! `library.rs`; compared here it took more CI time than all the others together.

use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

/// Largest program compared (bytes); see the module doc.
const MAX_PROGRAM_BYTES: u64 = 2_000_000;
/// Largest page accepted (bytes): "a few MB" whatever the program.
const MAX_PAGE_BYTES: u64 = 3_000_000;
const METHODS: [&str; 5] = ["none", "bspline", "arc", "nurbs", "trig"];
/// Fields that are wall-clock measurements, not results.
const TIMINGS: [&str; 6] = [
    "parse_s",
    "smooth_s",
    "plan_time_s",
    "stage_time_s",
    "real_time_factor",
    "end_to_end_real_time_factor",
];

fn gcode_dir() -> Option<PathBuf> {
    let base = std::env::var_os("NCSMOOTH_SHARED_DATA").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
        PathBuf::from,
    );
    let d = base.join("gcode");
    d.is_dir().then_some(d)
}

/// Compares `a` and `b` leaf by leaf (timings skipped); returns the leaves compared and
/// the differences found (path: a vs b).
fn diff(a: &Value, b: &Value, path: &str, leaves: &mut usize, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in x {
                if TIMINGS.contains(&k.as_str()) {
                    continue;
                }
                match y.get(k) {
                    Some(w) => diff(v, w, &format!("{path}.{k}"), leaves, out),
                    None => out.push(format!("{path}.{k} missing from plan")),
                }
            }
            for k in y.keys().filter(|k| !x.contains_key(*k)) {
                out.push(format!("{path}.{k} missing from compare"));
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                diff(v, w, &format!("{path}[{i}]"), leaves, out);
            }
        }
        _ => {
            *leaves += 1;
            if a != b {
                out.push(format!("{path}: {a} vs {b}"));
            }
        }
    }
}

fn ncsmooth(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_ncsmooth"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
#[ignore = "minutes in debug; CI runs it in release"]
fn compare_agrees_with_plan_on_every_shared_file() {
    let Some(dir) = gcode_dir() else {
        eprintln!(
            "SKIP compare_agrees_with_plan_on_every_shared_file: ../shared/data/gcode not found"
        );
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e != "md"))
        .collect();
    files.sort();
    files.retain(|f| {
        let small = std::fs::metadata(f).unwrap().len() <= MAX_PROGRAM_BYTES;
        if !small {
            println!("{}: left out (over {MAX_PROGRAM_BYTES} bytes)", f.display());
        }
        small
    });
    assert!(!files.is_empty());
    let tmp = std::env::temp_dir().join(format!("ncsmooth-compare-files-{}", std::process::id()));
    let mut total_leaves = 0;
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let out = tmp.join(&name);
        let t0 = std::time::Instant::now();
        let o = ncsmooth(&[
            "compare",
            f.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let compare_s = t0.elapsed().as_secs_f64();
        let page = std::fs::metadata(out.join("index.html")).unwrap().len();
        assert!(page <= MAX_PAGE_BYTES, "{name}: page of {page} bytes");
        let c: Value =
            serde_json::from_slice(&std::fs::read(out.join("compare.json")).unwrap()).unwrap();
        let mut leaves = 0;
        for (i, m) in METHODS.iter().enumerate() {
            let rep = out.join(format!("plan_{m}.json"));
            let o = ncsmooth(&[
                "plan",
                f.to_str().unwrap(),
                "--method",
                m,
                "--report",
                rep.to_str().unwrap(),
                "-q",
            ]);
            assert!(
                o.status.success(),
                "{name} {m}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let p: Value = serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
            let from_compare = &c["methods"][i]["plan"];
            assert_eq!(from_compare["method"], *m);
            let mut differences = Vec::new();
            diff(from_compare, &p, "", &mut leaves, &mut differences);
            assert!(differences.is_empty(), "{name} {m}: {differences:#?}");
        }
        total_leaves += leaves;
        println!(
            "{name}: compare {compare_s:.1} s, page {page} bytes, {leaves} fields of 5 plans equal to plan --report"
        );
        let _ = std::fs::remove_dir_all(&out);
    }
    println!("{} files, {total_leaves} fields equal", files.len());
    let _ = std::fs::remove_dir_all(&tmp);
}
