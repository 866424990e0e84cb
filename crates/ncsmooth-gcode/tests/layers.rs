//! The G-code crate's modules import downward only: the numbers and the data of a line
//! (`numbers`, `error`, `canon`, `source`, `polyline`) below the reader (`cursor` ->
//! `expr` -> `lexer` -> `interpreter` -> `stream`), the controllers (`controller`: the
//! capability table, block floors, LinuxCNC's model) above what they read, the writers
//! (`write`) above the controllers they write for, and the read-back budget (`budget`) on
//! top. Checked on the source text: every `crate::X` path outside comments in module `M`
//! must name a module of a lower rank than `M` (a module's own submodules excepted; a name
//! the crate root re-exports counts as the module it comes from, another crate's is
//! allowed, and a module or anything else defined inline in `lib.rs` is refused: use
//! the module's own path). `lib.rs` (the public facade: private modules, root
//! re-exports) is not checked, and neither is test code (`tests.rs`, `#[cfg(test)]` items).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Rank of each top-level module: a module may import only modules of lower rank.
const RANKS: [(&str, u32); 14] = [
    ("numbers", 0),
    ("error", 0),
    ("canon", 0),
    ("source", 0),
    ("polyline", 0),
    ("cursor", 1),
    ("expr", 2),
    ("lexer", 3),
    ("interpreter", 4),
    ("stream", 5),
    ("controller", 5),
    ("write", 6),
    ("budget", 7),
    ("job", 8),
];

fn rank(m: &str) -> Option<u32> {
    RANKS.iter().find(|(n, _)| *n == m).map(|&(_, r)| r)
}

/// The first path segments of the names in a `{ ... }` group starting at `rest` (after
/// the `{`): `crate::{a::b, c}` gives `a` and `c`.
fn group_names(rest: &str, out: &mut Vec<String>) {
    let mut depth = 0;
    let mut item = String::new();
    let mut items = Vec::new();
    for c in rest.chars() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => items.push(std::mem::take(&mut item)),
            _ => {}
        }
        item.push(c);
    }
    items.push(item);
    for item in items {
        let name: String = item
            .trim_start_matches(|c: char| c == ',' || c.is_whitespace())
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if !name.is_empty() {
            out.push(name);
        }
    }
}

/// The `crate::X` targets (and `super::X` ones when `top` is set: a file directly in
/// `src/`, whose parent is the crate root) of the non-test, non-comment code of `text`,
/// with their line numbers; a `{ }` group may span lines.
fn imports(text: &str, top: bool) -> Vec<(usize, String)> {
    // The code: comments cut and test items (from a `#[cfg(test)]` to the end of the
    // item after it) blanked, one line for one line.
    let mut code = String::new();
    let mut skipping = false;
    let mut depth = 0i32;
    for line in text.lines() {
        let kept = line.split("//").next().unwrap_or("");
        if kept.trim_start().starts_with("#[cfg(test)]") {
            skipping = true;
            depth = 0;
        } else if skipping {
            let opened = depth > 0 || kept.contains('{');
            depth += kept.matches('{').count() as i32 - kept.matches('}').count() as i32;
            skipping = if opened {
                depth > 0
            } else {
                !kept.trim_end().ends_with(';')
            };
        } else {
            code.push_str(kept);
        }
        code.push('\n');
    }
    let prefixes: &[&str] = if top {
        &["crate::", "super::"]
    } else {
        &["crate::"]
    };
    let mut out = Vec::new();
    for prefix in prefixes {
        let mut from = 0;
        while let Some(at) = code[from..].find(prefix) {
            let start = from + at;
            from = start + prefix.len();
            let line = code[..start].matches('\n').count() + 1;
            let before = code[..start].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue; // `foo_crate::x`, not a crate path
            }
            let rest = &code[from..];
            if let Some(group) = rest.strip_prefix('{') {
                let mut names = Vec::new();
                group_names(group, &mut names);
                out.extend(names.into_iter().map(|n| (line, n)));
                continue;
            }
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            out.push((line, name));
        }
    }
    out.sort();
    out
}

/// The names `lib.rs` re-exports (`pub use m::{A, b::C as D};`), each with the top-level
/// module it comes from (`None`: another crate's, as `ncsmooth::path::Units`); the modules
/// it defines inline (`pub mod writer { ... }`, the compatibility paths) come from `lib`,
/// which has no rank, even where a function of the same name is re-exported (`rewrite`).
type Roots = BTreeMap<String, Option<String>>;

fn root_reexports(lib: &str) -> Roots {
    let code: Vec<&str> = lib
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect();
    let code = code.join("\n");
    let mut out = Roots::new();
    let mut rest = code.as_str();
    while let Some(at) = rest.find("pub use ") {
        rest = &rest[at + "pub use ".len()..];
        let Some(end) = rest.find(';') else { break };
        let stmt = rest[..end].split_whitespace().collect::<Vec<_>>().join(" ");
        rest = &rest[end..];
        let stmt = stmt.trim_start_matches("crate::");
        let first = stmt.split("::").next().unwrap_or("");
        let from = rank(first).map(|_| first.to_string());
        let items: Vec<&str> = match stmt.find('{') {
            Some(b) => stmt[b + 1..].trim_end_matches('}').split(',').collect(),
            None => vec![stmt],
        };
        for item in items.iter().map(|i| i.trim()) {
            let name = match item.split_once(" as ") {
                Some((_, alias)) => alias.trim(),
                None => item.rsplit("::").next().unwrap_or(""),
            };
            if !name.is_empty() && name != "*" && name != "_" {
                out.insert(name.to_string(), from.clone());
            }
        }
    }
    let mut rest = code.as_str();
    while let Some(at) = rest.find("pub mod ") {
        rest = &rest[at + "pub mod ".len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if rest[name.len()..].trim_start().starts_with('{') {
            out.insert(name, Some("lib".to_string()));
        }
    }
    out
}

/// The imports of module `module` in `text` that do not go to a lower rank: a name the
/// crate root re-exports counts as the module it comes from (another crate's: allowed),
/// any other name that is not a ranked module (one defined in `lib.rs`, a compatibility
/// module) is refused.
fn violations(module: &str, text: &str, top: bool, roots: &Roots) -> Vec<(usize, String)> {
    let own = rank(module).expect("a ranked module");
    imports(text, top)
        .into_iter()
        .filter(|(_, target)| {
            let from = match (rank(target), roots.get(target)) {
                (Some(_), _) => target.as_str(),
                (None, Some(Some(m))) => m.as_str(),
                (None, Some(None)) => return false,
                (None, None) => return true,
            };
            from != module && rank(from).is_none_or(|r| r >= own)
        })
        .collect()
}

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
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
    let roots = root_reexports(&std::fs::read_to_string(src.join("lib.rs")).unwrap());
    assert!(
        roots.get("Dialect") == Some(&Some("controller".to_string())),
        "root re-exports not read: {roots:?}"
    );
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
        let Some(_) = rank(&module) else {
            panic!("module {module} has no rank in RANKS: place it in the layers");
        };
        *seen.entry(module.clone()).or_default() += 1;
        let top = rel.components().count() == 1;
        let text = std::fs::read_to_string(f).unwrap();
        for (line, target) in violations(&module, &text, top, &roots) {
            bad.push(format!(
                "{}:{line}: {module} imports crate::{target}",
                rel.display()
            ));
        }
    }
    let missing: Vec<_> = RANKS
        .iter()
        .filter(|(n, _)| !seen.contains_key(*n))
        .collect();
    assert!(missing.is_empty(), "ranked modules not found: {missing:?}");
    assert!(
        bad.is_empty(),
        "upward, sideways or root imports:\n{}",
        bad.join("\n")
    );
}

/// The check sees upward, sideways and root imports, in paths and groups (over several
/// lines too), outside comments and test items (it can fail).
#[test]
fn an_upward_import_is_seen() {
    let text = "use crate::error::ParseError;\n\
                // crate::write in a comment\n\
                use crate::{source::Plane, write::motion};\n\
                let x = crate::stream::f(); // sideways\n\
                use crate::Program;\n\
                #[cfg(test)]\n\
                use crate::budget;\n\
                #[cfg(test)]\n\
                mod tests {\n    use crate::budget;\n}\n\
                let y = crate::write::g();\n\
                use crate::{\n    numbers::push_fixed,\n    budget::{Budget, read_back},\n};\n";
    assert_eq!(
        imports(text, false),
        vec![
            (1, "error".to_string()),
            (3, "source".to_string()),
            (3, "write".to_string()),
            (4, "stream".to_string()),
            (5, "Program".to_string()),
            (12, "write".to_string()),
            (13, "budget".to_string()),
            (13, "numbers".to_string()),
        ]
    );
    let roots = root_reexports(
        "pub use controller::dialect::Dialect;\n\
         pub use interpreter::program::{\n    parse_str, Program,\n};\n\
         pub use ncsmooth::path::Units;\n\
         pub use write::rewrite::{rewrite, RewriteOptions};\n\
         pub mod numbers;\n\
         pub mod writer {\n    // compatibility path\n    pub use crate::numbers::*;\n}\n\
         pub mod rewrite {\n    pub use crate::write::rewrite::*;\n}\n",
    );
    assert_eq!(roots.len(), 7, "{roots:?}");
    assert_eq!(
        violations("controller", text, false, &roots),
        vec![
            (3, "write".to_string()),
            (4, "stream".to_string()),
            (12, "write".to_string()),
            (13, "budget".to_string()),
        ]
    );
    // A file directly in src/: `super::` is the crate root.
    assert_eq!(
        violations("lexer", "use super::interpreter::Interp;\n", true, &roots),
        vec![(1, "interpreter".to_string())]
    );
    assert!(violations("lexer", "use super::interpreter::Interp;\n", false, &roots).is_empty());
    // Root names count as their module; another crate's are allowed; a compatibility
    // module or a name the root does not re-export is refused.
    let text = "use crate::{Dialect, Units};\nuse crate::Program;\nuse crate::writer::push_fixed;\nuse crate::Nowhere;\n";
    assert_eq!(
        violations("write", text, false, &roots),
        vec![(3, "writer".to_string()), (4, "Nowhere".to_string())]
    );
    assert_eq!(
        violations("write", "use crate::rewrite::Emit;\n", false, &roots),
        vec![(1, "rewrite".to_string())]
    );
    assert_eq!(
        violations("stream", text, false, &roots),
        vec![
            (1, "Dialect".to_string()),
            (3, "writer".to_string()),
            (4, "Nowhere".to_string())
        ]
    );
    assert_eq!(
        violations("interpreter", "use crate::Program;\n", false, &roots),
        vec![]
    );
}
