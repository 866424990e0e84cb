//! The library example (`crates/ncsmooth-gcode/examples/smooth_file.rs`, included here as
//! it is) writes what `ncsmooth smooth FILE --method bspline --tol 0.01 --dialect D`
//! writes, byte for byte, on every program of `../shared/data/gcode`: for grbl against the
//! binary run beside it, for LinuxCNC (the default dialect) against the pinned golden hash
//! of the binary's output (`tests/golden/outputs.txt`, which `golden.rs` holds the binary
//! to). The plan example (`plan_file.rs`) writes the setpoints `ncsmooth plan FILE --method
//! bspline --feed F --acc A --setpoints OUT` writes. Ignored in debug builds; CI runs them
//! in release. Skip when `../shared` is absent.

mod common;
#[path = "../../ncsmooth-gcode/examples/smooth_file.rs"]
mod example;
#[path = "../../ncsmooth-gcode/examples/plan_file.rs"]
mod plan_example;

use common::{fnv1a, run, shared_data, tmpdir, without_header};
use ncsmooth_gcode::Dialect;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The pinned `hash bytes` of `smooth FILE --method bspline --tol 0.01`, by file name.
fn golden_bspline() -> BTreeMap<String, String> {
    let golden = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/outputs.txt");
    std::fs::read_to_string(golden)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            (f.len() == 5 && f[0] == "gcode" && f[2] == "bspline")
                .then(|| (f[1].to_string(), format!("{} {}", f[3], f[4])))
        })
        .collect()
}

#[test]
#[ignore = "minutes in release; CI runs it with --release --ignored"]
fn the_library_example_writes_what_smooth_writes() {
    let Some(data) = shared_data() else {
        eprintln!("SKIP the_library_example_writes_what_smooth_writes: ../shared/data not found");
        return;
    };
    let golden = golden_bspline();
    let dir = tmpdir("library");
    let mut files: Vec<PathBuf> = std::fs::read_dir(data.join("gcode"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_none_or(|x| x != "md"))
        .collect();
    files.sort();
    assert!(files.len() >= 13, "only {} programs", files.len());
    for f in &files {
        let path = f.to_str().unwrap();
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        // LinuxCNC: the library's bytes hash to the binary's pinned output.
        let lib = example::smooth_file(path, Dialect::LinuxCnc).unwrap();
        let got = format!(
            "{:016x} {}",
            fnv1a(without_header(&lib)),
            without_header(&lib).len()
        );
        assert_eq!(Some(&got), golden.get(&name), "{name} linuxcnc");
        // grbl: the binary, run beside the library.
        let out = dir.join(format!("{name}_grbl.ngc"));
        let args = ["smooth", path, "--method", "bspline", "--tol", "0.01"];
        let cli = std::thread::scope(|s| {
            let cli = s.spawn(|| {
                let o = run(&[
                    &args[..],
                    &["--dialect", "grbl", "-o", out.to_str().unwrap()],
                ]
                .concat());
                assert!(o.status.success(), "{name}: {}", common::stderr(&o));
                std::fs::read(&out).unwrap()
            });
            let lib = example::smooth_file(path, Dialect::Grbl).unwrap();
            (cli.join().unwrap(), lib)
        });
        assert!(
            cli.0 == cli.1,
            "{name} grbl: the library's G-code differs from the binary's"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
#[ignore = "seconds in release; CI runs it with --release --ignored"]
fn the_plan_example_writes_what_plan_writes() {
    let Some(data) = shared_data() else {
        eprintln!("SKIP the_plan_example_writes_what_plan_writes: ../shared/data not found");
        return;
    };
    let dir = tmpdir("library-plan");
    for f in [
        data.join("profiles/butterfly_1000.ngc"),
        data.join("gcode/cncjs_jsdc.gcode"),
        data.join("gcode/linuxcnc_rgh.ngc"),
    ] {
        let path = f.to_str().unwrap();
        let out = dir.join("cli.csv");
        let o = run(&[
            "plan",
            path,
            "--method",
            "bspline",
            "--feed",
            "40",
            "--acc",
            "300",
            "--setpoints",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{path}: {}", common::stderr(&o));
        let mut lib = Vec::new();
        let report = plan_example::plan_file(path, 40.0, 300.0, &mut lib).unwrap();
        assert!(report.plan.limits_held);
        assert!(
            std::fs::read(&out).unwrap() == lib,
            "{path}: the library's setpoints differ from the binary's"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
