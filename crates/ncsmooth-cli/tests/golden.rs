//! Golden outputs: the setpoints of `butterfly_1000` and `crown` for every method (and of
//! `crown` in jerk mode) and the
//! smoothed G-code of every shared program for every method, pinned by an FNV-1a hash of
//! their bytes (the G-code's trailing `;` header lines, which name paths and the version,
//! left out) in `tests/golden/outputs.txt`. A change of any output byte fails the test
//! with the list of what changed; a change meant to alter outputs rewrites the file with
//! `NCSMOOTH_BLESS=1 cargo test --release -p ncsmooth-cli --test golden -- --ignored` and
//! says why in its commit. Ignored in debug builds (a minute in release); CI runs it in
//! release. Skips with a message when `../shared` is absent.

mod common;

use common::{fnv1a, without_header};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const METHODS: [&str; 5] = ["none", "bspline", "arc", "nurbs", "trig"];
/// The plan settings of the pinned setpoints (issue 17's trapezoid setting).
const PLAN_ARGS: [&str; 6] = ["--tol", "0.01", "--feed", "50", "--acc", "500"];

fn golden_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/outputs.txt")
}

fn run(args: &[&str]) -> bool {
    let o = Command::new(env!("CARGO_BIN_EXE_ncsmooth"))
        .args(args)
        .output()
        .unwrap();
    if !o.status.success() {
        eprintln!("{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    }
    o.status.success()
}

/// `key -> "hash bytes"` of every pinned output.
fn outputs(data: &Path, dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    // A run that fails is pinned as such ("failed -").
    let mut put = |key: String, bytes: Option<&[u8]>| {
        let v = bytes.map_or("failed -".to_string(), |b| {
            format!("{:016x} {}", fnv1a(b), b.len())
        });
        out.insert(key, v);
    };
    for profile in ["butterfly_1000", "crown"] {
        let f = data.join("profiles").join(format!("{profile}.ngc"));
        for m in METHODS {
            let csv = dir.join(format!("{profile}_{m}.csv"));
            let ok = run(&[
                &["plan", f.to_str().unwrap(), "--method", m],
                &PLAN_ARGS[..],
                &["--setpoints", csv.to_str().unwrap()],
            ]
            .concat());
            let bytes = ok.then(|| std::fs::read(&csv).unwrap());
            put(format!("setpoints {profile} {m}"), bytes.as_deref());
        }
    }
    // Jerk mode (issue 17's 50 mm/s, 500 mm/s^2, 5000 mm/s^3) on crown.
    let f = data.join("profiles/crown.ngc");
    for m in METHODS {
        let csv = dir.join(format!("crown_{m}_jerk.csv"));
        let ok = run(&[
            &["plan", f.to_str().unwrap(), "--method", m],
            &PLAN_ARGS[..],
            &["--jerk", "5000", "--setpoints", csv.to_str().unwrap()],
        ]
        .concat());
        let bytes = ok.then(|| std::fs::read(&csv).unwrap());
        put(format!("setpoints crown-jerk5000 {m}"), bytes.as_deref());
    }
    let mut programs: Vec<PathBuf> = ["gcode", "more-gcode"]
        .iter()
        .filter_map(|d| std::fs::read_dir(data.join(d)).ok())
        .flatten()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_none_or(|x| x != "md"))
        .collect();
    programs.sort();
    for p in programs {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        for m in METHODS {
            let ngc = dir.join(format!("{name}_{m}.ngc"));
            let ok = run(&[
                "smooth",
                p.to_str().unwrap(),
                "--method",
                m,
                "--tol",
                "0.01",
                "-o",
                ngc.to_str().unwrap(),
            ]);
            let bytes = ok.then(|| std::fs::read(&ngc).unwrap());
            put(
                format!("gcode {name} {m}"),
                bytes.as_deref().map(without_header),
            );
        }
    }
    out
}

#[test]
#[ignore = "a minute in release; CI runs it with --release --ignored"]
fn outputs_equal_the_golden_files() {
    let Some(data) = common::shared_data() else {
        eprintln!("SKIP outputs_equal_the_golden_files: ../shared/data not found");
        return;
    };
    let dir = std::env::temp_dir().join(format!("ncsmooth-golden-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let got = outputs(&data, &dir);
    std::fs::remove_dir_all(&dir).ok();
    let text: String = got.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
    if std::env::var_os("NCSMOOTH_BLESS").is_some() {
        std::fs::write(golden_file(), &text).unwrap();
        eprintln!(
            "blessed {} outputs into {}",
            got.len(),
            golden_file().display()
        );
        return;
    }
    let want: BTreeMap<String, String> = std::fs::read_to_string(golden_file())
        .unwrap()
        .lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            (f.len() == 5).then(|| (f[..3].join(" "), f[3..].join(" ")))
        })
        .collect();
    let changed: Vec<String> = want
        .keys()
        .chain(got.keys())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .filter(|k| want.get(*k) != got.get(*k))
        .map(|k| format!("{k}: golden {:?}, now {:?}", want.get(k), got.get(k)))
        .collect();
    assert!(
        changed.is_empty(),
        "{} outputs changed:\n{}",
        changed.len(),
        changed.join("\n")
    );
    assert!(got.len() >= 15 + 5 * 13, "only {} outputs", got.len());
}

/// The header lines are cut, and only those.
#[test]
fn the_header_is_left_out_of_the_hash() {
    assert_eq!(
        without_header(b"G1 X1\nM2\n; made by\n; ncsmooth\n"),
        b"G1 X1\nM2\n"
    );
    assert_eq!(without_header(b"G1 X1\r\n; a\r\n"), b"G1 X1\r\n");
    assert_eq!(without_header(b"G1 X1\n"), b"G1 X1\n");
    assert_eq!(without_header(b"; only\n"), b"");
    assert_ne!(fnv1a(b"G1 X1"), fnv1a(b"G1 X2"));
}
