//! Dev tool: smooths a file with a method and prints the rewritten program (no
//! verification), to inspect what the rewrite writes.
//!
//! `cargo run --release -p ncsmooth-gcode --example rewrite_dump -- FILE METHOD TOL`

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let src = std::fs::read(&a[1]).expect("readable file");
    let p = ncsmooth_gcode::parse_bytes(&src, &a[1], &Default::default()).expect("parses");
    let method = ncsmooth::smooth::Method::from_name(&a[2]).expect("method");
    let tol: f64 = a[3].parse().expect("tol");
    let opts = ncsmooth::smooth::SmoothOptions::default()
        .with_method(method)
        .with_tol_mm(tol * 0.8);
    let s = ncsmooth::smooth::smooth(&p.toolpath, &opts).expect("smooths");
    check_order(&s.toolpath);
    if let Ok(r) = std::env::var("TAGS") {
        let (a, b) = r.split_once('-').expect("FROM-TO");
        dump_tags(&p.toolpath, a.parse().unwrap(), b.parse().unwrap());
        eprintln!("--- smoothed");
        dump_tags(&s.toolpath, a.parse().unwrap(), b.parse().unwrap());
    }
    let out = ncsmooth_gcode::rewrite(
        &src,
        &p,
        &s.toolpath,
        &ncsmooth_gcode::RewriteOptions::new(4, tol * 0.1),
    )
    .expect("rewrites");
    use std::io::Write;
    std::io::stdout().write_all(&out).expect("stdout");
}

#[allow(dead_code)]
fn dump_tags(tp: &ncsmooth::Toolpath, from: u32, to: u32) {
    use ncsmooth::geom::ParamCurve;
    for m in tp.moves().filter(|m| (from..=to).contains(&m.line)) {
        eprintln!(
            "line {} {:?} {:?} -> {:?}",
            m.line,
            m.kind,
            m.segment.start(),
            m.segment.end()
        );
    }
}

#[allow(dead_code)]
fn check_order(tp: &ncsmooth::Toolpath) {
    let mut last = 0;
    for m in tp.moves() {
        if m.line < last {
            eprintln!("tag goes back: {} after {}", m.line, last);
        }
        last = last.max(m.line);
    }
}
