//! `--method trig` on the benchmark profiles and on every real G-code file of
//! ../shared/data (skipped with a message when absent): the two-sided deviation holds
//! `tol` (round corners), loops pass their corners and stay within the loop size, and
//! there is no tangent break except the counted stops and the chain ends at events.
//! The large files are `#[ignore]`d (slow in debug; the lead runs them in release).

use ncsmooth::geom::{ParamCurve, Segment, Vec3};
use ncsmooth::smooth::trig_corner::{
    check_loops, is_loop, without_loops, CornerStyle, TrigOptions,
};
use ncsmooth::smooth::{smooth, Method, SmoothOptions};
use ncsmooth::verify::{continuity, deviation};
use ncsmooth::{Block, MoveKind, Toolpath};

mod common;
use common::{data_path, load};

/// Feed-to-feed joints across a non-move block (an event ends a chain there, and chain
/// ends are kept exactly, so such a joint may be a tangent break of the program itself).
fn chain_break_joints(tp: &Toolpath) -> usize {
    let mut n = 0;
    let mut prev_feed = false;
    let mut event_between = false;
    for b in &tp.blocks {
        match b {
            Block::Move(m) => {
                let feed = m.kind == MoveKind::Feed;
                if prev_feed && feed && event_between {
                    n += 1;
                }
                prev_feed = feed;
                event_between = false;
            }
            Block::Event(_) => event_between = true,
        }
    }
    n
}

/// Smooths `rel` and checks the contract; returns the worst deviation / tol.
fn run(rel: &str, tol: f64, corner: CornerStyle) -> Option<f64> {
    let tp = load(rel)?;
    let opts = SmoothOptions::default()
        .with_method(Method::Trig)
        .with_tol_mm(tol)
        .with_trig(TrigOptions::default().with_corner(corner));
    let t = std::time::Instant::now();
    let s = smooth(&tp, &opts).expect("valid options");
    let secs = t.elapsed().as_secs_f64();
    let out = without_loops(&s.toolpath);
    let mut loops = 0;
    if let CornerStyle::Loop { loop_size_mm } = corner {
        // Programmed end points sorted by x: a loop's corner is looked up in O(log n)
        // (a scan per loop made this test quadratic: minutes on stellabee1).
        let mut ends: Vec<Vec3> = tp.moves().map(|p| p.segment.end()).collect();
        ends.sort_by(|a, b| a.x.total_cmp(&b.x));
        let is_programmed_end = |q: Vec3| {
            let from = ends.partition_point(|p| p.x < q.x - 1e-9);
            ends[from..]
                .iter()
                .take_while(|p| p.x <= q.x + 1e-9)
                .any(|p| p.dist(q) <= 1e-9)
        };
        for m in s.toolpath.moves() {
            if let (true, Segment::Trig(c)) = (is_loop(&m.segment), &m.segment) {
                loops += 1;
                for i in 0..=400 {
                    let e = c.eval(i as f64 / 400.0).dist(c.q0);
                    assert!(e <= loop_size_mm, "{rel}: loop excursion {e}");
                }
                assert!(c.eval(1.0).dist(c.eval(0.0)) <= 1e-9);
                assert!(
                    is_programmed_end(c.eval(0.0)),
                    "{rel}: loop corner is not a programmed vertex"
                );
            }
        }
        let lc = check_loops(&s.toolpath, &tp, loop_size_mm);
        assert_eq!(lc.loops, loops);
        assert!(lc.within(loop_size_mm), "{rel}: {lc:?}");
    }
    let dev = deviation(&out, &tp, tol * 1e-3);
    // Without the loops the legs still reach every corner: both sides hold.
    let worst = dev.max_mm();
    let c = continuity(&s.toolpath);
    let breaks = chain_break_joints(&s.toolpath);
    eprintln!(
        "{rel}: tol {tol} worst/tol {:.4} ({dev:?}); {:.3} s; corners smoothed {} straight {} \
         stopped {} arc joints {} runs {} loops {loops}; G0 joints {} (stops + chain breaks {})",
        worst / tol,
        secs,
        s.report.corners_smoothed,
        s.report.corners_straight,
        s.report.corners_stopped,
        s.report.arc_joints,
        s.report.runs_fitted,
        c.g0,
        s.report.corners_stopped + breaks,
    );
    assert!(
        worst <= tol,
        "{rel}: deviation {worst} > tol {tol}: {dev:?}"
    );
    assert_eq!(c.gaps, 0, "{rel}: {c:?}");
    assert!(
        c.g0 <= s.report.corners_stopped + breaks,
        "{rel}: {c:?} {:?}",
        s.report
    );
    assert_eq!(
        s.toolpath.events().count(),
        tp.events().count(),
        "{rel}: events kept"
    );
    assert!(s.toolpath.end_point().dist(tp.end_point()) <= 1e-9);
    Some(worst / tol)
}

#[test]
fn profiles_hold_tol() {
    for f in [
        "butterfly_80.ngc",
        "butterfly_1000.ngc",
        "crown.ngc",
        "hexagon3d.ngc",
    ] {
        for tol in [0.01, 0.05] {
            run(&format!("profiles/{f}"), tol, CornerStyle::Round);
        }
        run(
            &format!("profiles/{f}"),
            0.01,
            CornerStyle::Loop { loop_size_mm: 1.0 },
        );
    }
}

const SMALL_FILES: [&str; 8] = [
    "camotics_tiny_cat_outline.ngc",
    "cncjs_jsdc.gcode",
    "linuxcnc_51MeanderAve.ngc",
    "linuxcnc_Cereal.ngc",
    "linuxcnc_blur_torus.ngc",
    "linuxcnc_rgh.ngc",
    "camotics_vcarve.ngc",
    "linuxcnc_LHchips4.ngc",
];

const LARGE_FILES: [&str; 5] = [
    "camotics_bear.nc",
    "camotics_tiger.nc",
    "cncjs_sample_slic3r.gcode",
    "linuxcnc_stellabee1.ngc",
    "ugs_Gates_combined_R12.nc",
];

#[test]
fn small_gcode_files_hold_tol() {
    for f in SMALL_FILES {
        run(&format!("gcode/{f}"), 0.01, CornerStyle::Round);
    }
}

#[test]
#[ignore = "slow in debug: run in release"]
fn large_gcode_files_hold_tol() {
    for f in LARGE_FILES {
        run(&format!("gcode/{f}"), 0.01, CornerStyle::Round);
    }
}

#[test]
#[ignore = "slow in debug: run in release"]
fn all_gcode_files_with_loops() {
    for f in SMALL_FILES.iter().chain(&LARGE_FILES) {
        run(
            &format!("gcode/{f}"),
            0.01,
            CornerStyle::Loop { loop_size_mm: 0.5 },
        );
    }
}

#[test]
fn every_file_is_listed() {
    let Some(dir) = data_path("gcode") else {
        return;
    };
    let rd = std::fs::read_dir(&dir).expect("readable data directory");
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if name.ends_with(".md") {
            continue;
        }
        assert!(
            SMALL_FILES.contains(&name.as_str()) || LARGE_FILES.contains(&name.as_str()),
            "{name} is not tested"
        );
    }
}
