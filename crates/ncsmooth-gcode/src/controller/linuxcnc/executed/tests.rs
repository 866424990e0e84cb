use super::*;
use crate::{parse_str, ParseOptions};
use ncsmooth::verify::deviation;

/// Accuracy of the measurements (mm).
const ACCURACY_MM: f64 = 1e-6;

fn program(src: &str) -> Program {
    parse_str(src, "t.ngc", &ParseOptions::default()).unwrap()
}

fn executed(written: &str, programmed: &str, cap_mm: f64, counted_mm: f64) -> Executed {
    let w = program(written);
    let p = program(programmed);
    let dev = deviation(&w.toolpath, &p.toolpath, ACCURACY_MM);
    linuxcnc_executed(&w, &p.toolpath, &dev, cap_mm, counted_mm, ACCURACY_MM)
}

#[test]
fn largest_blend_of_a_right_angle_is_p_from_the_corner() {
    let a = Line::new(Vec3::new(-10.0, 0.0, 0.0), Vec3::ZERO);
    let b = Line::new(Vec3::ZERO, Vec3::new(0.0, 10.0, 0.0));
    let arc = BlendArc::new(&a, &b, 0.01).unwrap();
    // Its middle is P from the corner, its ends are where it leaves the lines, tangent.
    assert!((arc.arc_point(0.5).dist(Vec3::ZERO) - 0.01).abs() < 1e-12);
    assert!(arc.arc_point(0.0).dist(Vec3::new(-arc.d, 0.0, 0.0)) < 1e-12);
    assert!(arc.arc_point(1.0).dist(Vec3::new(0.0, arc.d, 0.0)) < 1e-12);
    // theta = 45 deg: d = cos(theta) P / (1 - sin(theta)).
    let s = std::f64::consts::FRAC_1_SQRT_2;
    assert!((arc.d - s * 0.01 / (1.0 - s)).abs() < 1e-12);
    // Half a short line limits it.
    let short = Line::new(Vec3::ZERO, Vec3::new(0.0, 0.01, 0.0));
    assert!((BlendArc::new(&a, &short, 0.01).unwrap().d - 0.005).abs() < 1e-15);
    // No blend of collinear or reversing lines.
    let on = Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
    let back = Line::new(Vec3::ZERO, Vec3::new(-10.0, 0.0, 0.0));
    assert!(BlendArc::new(&a, &on, 0.01).is_none() && BlendArc::new(&a, &back, 0.01).is_none());
}

#[test]
fn a_blended_corner_deviates_by_p_at_the_vertex() {
    let prog = "G21 G0 X0 Y0\nG1 X10 F600\nG1 Y10\n";
    let written = "G21 G64 P0.01 Q0\nG0 X0 Y0\nG1 X10 F600\nG1 Y10\n";
    let e = executed(written, prog, 0.01, 0.01);
    assert_eq!((e.blends_modelled, e.blends_counted), (1, 0));
    // The corner (10, 0) is P from the largest blend (widened by LinuxCNC's measured
    // excess); the blend's middle is that times cos(45) from the lines.
    let widen = 1.0 + LINUXCNC_BLEND_EXCESS_SHARE;
    assert!(
        (e.vertex_to_path_mm - 0.01 * widen).abs() < ACCURACY_MM,
        "{e:?}"
    );
    let s = std::f64::consts::FRAC_1_SQRT_2;
    assert!(
        (e.path_to_programmed_mm - 0.01 * widen * s).abs() < ACCURACY_MM,
        "{e:?}"
    );
    // Capped at a smaller P, it is that P.
    let e = executed(written, prog, 0.004, 0.01);
    assert!(
        (e.vertex_to_path_mm - 0.004 * widen).abs() < ACCURACY_MM,
        "{e:?}"
    );
    // G61 blends nothing; a naive-CAM Q is counted, not modelled.
    let e = executed(&written.replace("G64 P0.01 Q0", "G61"), prog, 0.01, 0.01);
    assert!(e.max_mm() < ACCURACY_MM && e.blends_modelled == 0, "{e:?}");
    let e = executed(&written.replace("Q0", "Q0.002"), prog, 0.01, 0.012);
    assert_eq!(e.blends_counted, 1);
    assert!((e.max_mm() - 0.012).abs() < ACCURACY_MM, "{e:?}");
}

/// A circle of radius 5 flattened with chord error `c` and written under `G64 P<c> Q0`:
/// LinuxCNC's blends follow the chords' inscribed circle, so the executed path is about
/// `c` from the circle, not `c + P` (the sum a blanket budget pays).
#[test]
fn blends_of_a_flattened_circle_stay_within_the_chord() {
    let r = 5.0_f64;
    let c = 0.002;
    let n = (std::f64::consts::PI / (1.0 - c / r).acos()).ceil() as usize;
    let pt = |k: usize, m: usize| {
        let a = std::f64::consts::TAU * k as f64 / m as f64;
        (r * a.cos(), r * a.sin())
    };
    let mut written = format!("G21 G64 P{c} Q0\nG0 X{r} Y0\n");
    for k in 1..=n {
        let (x, y) = pt(k, n);
        written += &format!("G1 X{x:.9} Y{y:.9} F600\n");
    }
    let mut prog = format!("G21\nG0 X{r} Y0\n");
    for k in 1..=20 * n {
        let (x, y) = pt(k, 20 * n);
        prog += &format!("G1 X{x:.9} Y{y:.9} F600\n");
    }
    let e = executed(&written, &prog, c, c);
    assert!(e.blends_modelled >= n - 1);
    // Within c of the circle (plus the fine programmed polygon's own chord error), where
    // the largest arcs run all along.
    let fine = r * (1.0 - (std::f64::consts::PI / (20 * n) as f64).cos());
    let widen = 1.0 + LINUXCNC_BLEND_EXCESS_SHARE;
    assert!(e.max_mm() <= c * widen + fine + ACCURACY_MM, "{e:?}");
    assert!(e.max_mm() > 0.9 * c, "{e:?}");
}

/// A join that is not modelled (here a naive-CAM `Q`) is counted as the written path's
/// deviation near it plus the caller's blend, there and only there.
#[test]
fn a_join_not_modelled_is_counted_where_it_is() {
    let prog = "G21 G0 X0 Y0\nG1 X10 F600\nG1 X20 Y0\nG1 X30 Y0\nG1 X40 Y1\nG1 X50 Y0\n";
    // The written path strays 0.004 mm at (20, 0.004), among modelled joins; the last two
    // joins are under a Q.
    let written = "G21 G64 P0.002 Q0\nG0 X0 Y0\nG1 X10 F600\nG1 X20 Y0.004\nG1 X30 Y0\n\
                   G64 P0.002 Q0.001\nG1 X40 Y1\nG1 X50 Y0\n";
    let e = executed(written, prog, 0.002, 0.001);
    assert_eq!((e.blends_modelled, e.blends_counted), (2, 2));
    // Near the Q: at most 0.002 written (the half line from (25, 0.002)) plus 0.001; the
    // largest is the written 0.004 at (20, 0.004), not 0.004 + 0.001.
    assert!((e.path_to_programmed_mm - 0.004).abs() < 1e-4, "{e:?}");
}

#[test]
fn a_feed_move_and_a_rapid_are_not_blended() {
    // LinuxCNC stops between a feed move and a rapid (tp.c tpCheckCanonType): the corner
    // at (10, 0) is run exactly whatever the P, both ways.
    let prog = "G21 G0 X0 Y0\nG1 X10 F600\nG0 Y10\nG1 X20\n";
    let written = "G21 G64 P0.01 Q0\nG0 X0 Y0\nG1 X10 F600\nG0 Y10\nG1 X20\n";
    let e = executed(written, prog, 0.01, 0.01);
    assert_eq!((e.blends_modelled, e.blends_counted), (0, 0), "{e:?}");
    assert!(e.max_mm() < ACCURACY_MM, "{e:?}");
    // Two feed moves at the same corner are.
    let feeds = "G21 G64 P0.01 Q0\nG0 X0 Y0\nG1 X10 F600\nG1 Y10\nG1 X20\n";
    let prog = "G21 G0 X0 Y0\nG1 X10 F600\nG1 Y10\nG1 X20\n";
    assert_eq!(executed(feeds, prog, 0.01, 0.01).blends_modelled, 2);
}

#[test]
fn a_line_passing_near_a_blend_does_not_inflate_its_bound() {
    // A right-angle corner at the origin blended within 0.008, and a third programmed
    // line across the corner's inside, 0.0112 from the corner but nearer the blend arc's
    // middle than the corner's own lines are. The blend region is within 0.008 (widened
    // by LinuxCNC's measured excess) of the corner's lines; measured against the third
    // line alone its corner at the origin would be 0.0112 away.
    let (x0, y0) = (-0.715_03, -0.699_18);
    let (x1, y1) = (0.699_18, 0.715_03);
    let moves = format!("G0 X0 Y10\nG1 Y0 F600\nG1 X-10\nG0 X{x0} Y{y0}\nG1 X{x1} Y{y1}\n");
    let prog = format!("G21 {moves}");
    let written = format!("G21 G64 P0.008 Q0\n{moves}");
    let e = executed(&written, &prog, 0.01, 0.01);
    assert_eq!(e.blends_modelled, 1, "{e:?}");
    let widen = 1.0 + LINUXCNC_BLEND_EXCESS_SHARE;
    assert!(
        e.path_to_programmed_mm <= 0.008 * widen + ACCURACY_MM,
        "{e:?}"
    );
}

/// Moves written as programmed (arcs and spirals too) add only the counted blend at the
/// joins that are not modelled; an arc written beside the programmed one is measured by
/// its pieces' triangles and settles on its offset.
#[test]
fn arcs_at_counted_joins_are_measured_not_given_up() {
    let prog = "G21 G0 X0 Y0\nG1 X10 F600\nG3 X20 Y0 I5 J0\nG2 X30 Y0.002 I5 J0\nG1 X40\n";
    let e = executed(prog, prog, 0.01, 0.003);
    assert_eq!(e.blends_counted, 3, "{e:?}");
    assert!(
        (e.path_to_programmed_mm - 0.003).abs() < ACCURACY_MM,
        "{e:?}"
    );
    // The first arc written 0.002 mm outside the programmed one (radius 5.002).
    let written = "G21 G0 X0 Y0\nG1 X9.998 F600\nG3 X20.002 Y0 I5.002 J0\nG1 X20 Y0\n\
                   G2 X30 Y0.002 I5 J0\nG1 X40\n";
    let e = executed(written, prog, 0.01, 0.003);
    assert!(
        (e.path_to_programmed_mm - 0.005).abs() < 2.0 * ACCURACY_MM,
        "{e:?}"
    );
}

proptest::proptest! {
    /// The triangle of an arc piece, widened by its `e`, holds the piece: the distance to
    /// any line over the piece is at most its largest at the triangle's corners plus `e`.
    #[test]
    fn an_arc_piece_lies_in_its_triangle(
        r in 0.1f64..50.0,
        sweep in -6.0f64..6.0,
        spiral in -0.5f64..0.5,
        axial in -2.0f64..2.0,
        t0 in 0.0f64..1.0,
        w in 0.0f64..0.3,
        l in proptest::array::uniform6(-60.0f64..60.0),
    ) {
        let a = ncsmooth::geom::Arc {
            center: Vec3::new(1.0, -2.0, 0.5),
            radius: r,
            u: Vec3::X,
            v: Vec3::Y,
            sweep,
            axial: Vec3::new(0.0, 0.0, axial),
            spiral,
        };
        let t1 = (t0 + w).min(1.0);
        let line = Line::new(Vec3::new(l[0], l[1], l[2]), Vec3::new(l[3], l[4], l[5]));
        if let Some((hull, e)) = arc_piece_hull(&a, t0, t1) {
            let bound = hull.iter().map(|&v| line.dist_sq(v)).fold(0.0, f64::max).sqrt() + e;
            for i in 0..=50 {
                let p = a.eval(t0 + (t1 - t0) * i as f64 / 50.0);
                proptest::prop_assert!(line.dist_sq(p).sqrt() <= bound + 1e-9, "{i}");
            }
        }
    }
}
