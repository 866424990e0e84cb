//! The core's modules import downward only: geom -> path -> verify -> smooth -> feed
//! (planning) -> interp (setpoints), with the utilities (`par`, `decimal`) below all and
//! the data (`profiles`) and statistics (`stats`) beside the layer they need. Checked on
//! the source text: every `crate::X` path outside comments in module `M` must name a
//! module of a lower rank than `M` (a module's own submodules excepted). Test modules
//! (`tests.rs`, `#[cfg(test)]` blocks) may use anything.

use std::collections::BTreeMap;
use std::path::Path;

/// Rank of each top-level module: a module may import only modules of lower rank.
const RANKS: [(&str, u32); 10] = [
    ("par", 0),
    ("decimal", 0),
    ("geom", 1),
    ("path", 2),
    ("profiles", 2),
    ("verify", 3),
    ("smooth", 4),
    ("stats", 5),
    ("feed", 5),
    ("interp", 6),
];

fn rank(m: &str) -> Option<u32> {
    RANKS.iter().find(|(n, _)| *n == m).map(|&(_, r)| r)
}

/// The `crate::X` targets of the non-test, non-comment lines of `text`.
fn imports(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break; // test module at the end of the file
        }
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find("crate::") {
            rest = &rest[at + "crate::".len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            out.push((i + 1, name));
        }
    }
    out
}

fn files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn modules_import_downward_only() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut all = Vec::new();
    files(&src, &mut all);
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut bad = Vec::new();
    for f in &all {
        let rel = f.strip_prefix(&src).unwrap();
        let module = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if module == "lib" || rel.file_name().is_some_and(|n| n == "tests.rs") {
            continue;
        }
        let Some(own) = rank(&module) else {
            panic!("module {module} has no rank in RANKS: place it in the layers");
        };
        *seen.entry(module.clone()).or_default() += 1;
        for (line, target) in imports(&std::fs::read_to_string(f).unwrap()) {
            if target == module {
                continue;
            }
            match rank(&target) {
                Some(r) if r < own => {}
                _ => bad.push(format!(
                    "{}:{line}: {module} imports crate::{target}",
                    rel.display()
                )),
            }
        }
    }
    assert!(seen.len() >= RANKS.len() - 1, "modules found: {seen:?}");
    assert!(
        bad.is_empty(),
        "upward or sideways imports:\n{}",
        bad.join("\n")
    );
}

/// The check sees an upward import (it can fail).
#[test]
fn an_upward_import_is_seen() {
    let found = imports("use crate::geom::Vec3;\n// crate::interp in a comment\nlet x = crate::interp::f();\n#[cfg(test)]\nuse crate::smooth;\n");
    assert_eq!(
        found,
        vec![(1, "geom".to_string()), (3, "interp".to_string())]
    );
}
