//! Continuity audit: at every joint between two consecutive moves, the position gap, the
//! angle between the end tangent of one and the start tangent of the next, and the jump of
//! the curvature vector. Each feed-to-feed joint is classified:
//!
//! * **G0**: gap-free but a tangent break (angle above [`TANGENT_TOL_DEG`]): the machine
//!   must stop there or accept an infinite acceleration;
//! * **G1**: tangent-continuous, but the curvature vector jumps by more than
//!   [`CURVATURE_ABS_TOL`] + [`CURVATURE_REL_TOL`] x the larger curvature: a finite
//!   acceleration step;
//! * **G2**: curvature-continuous within those tolerances.
//!
//! Joints with a position gap above [`GAP_TOL_MM`] are counted as gaps (not classified);
//! joints next to a zero-length move as degenerate; joints involving a rapid as rapid
//! joints (rapids are never smoothed).

use crate::geom::{ParamCurve, ParamCurveCurvature, Segment, Vec3};
use crate::path::{Block, MoveKind, Toolpath};
use serde::Serialize;

/// Largest position gap (mm) of a continuous joint.
pub const GAP_TOL_MM: f64 = 1e-6;
/// Largest tangent angle (degrees) of a tangent-continuous joint: 0.01 deg turns a
/// 1 m/s feed by 0.17 mm/s, far below any servo's following error.
pub const TANGENT_TOL_DEG: f64 = 0.01;
/// Absolute curvature-jump tolerance (1/mm) of a G2 joint: a radius of 10 m.
pub const CURVATURE_ABS_TOL: f64 = 1e-4;
/// Relative curvature-jump tolerance of a G2 joint.
pub const CURVATURE_REL_TOL: f64 = 1e-3;
/// Length (mm) under which a move counts as zero-length.
pub const DEGENERATE_MM: f64 = 1e-9;

/// Class of a joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum JointClass {
    /// Position gap.
    Gap,
    /// Next to a zero-length move (no tangent).
    Degenerate,
    /// Involves a rapid.
    Rapid,
    /// Tangent break.
    G0,
    /// Tangent-continuous, curvature jump.
    G1,
    /// Curvature-continuous.
    G2,
}

/// One joint.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Joint {
    /// Index of the move that ends at the joint (among moves).
    pub move_index: usize,
    /// Source line of the move that starts at the joint.
    pub line: u32,
    /// Position of the joint.
    pub at: Vec3,
    /// Position gap (mm).
    pub gap_mm: f64,
    /// Tangent angle (degrees).
    pub angle_deg: f64,
    /// Magnitude of the curvature-vector jump (1/mm).
    pub curvature_jump: f64,
    /// Classification.
    pub class: JointClass,
}

/// Summary of a continuity audit.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Continuity {
    /// Joints examined.
    pub joints: usize,
    /// Position gaps.
    pub gaps: usize,
    /// Joints next to zero-length moves.
    pub degenerate: usize,
    /// Joints involving a rapid.
    pub rapid: usize,
    /// Feed joints with a tangent break.
    pub g0: usize,
    /// Feed joints, tangent-continuous with a curvature jump.
    pub g1: usize,
    /// Feed joints, curvature-continuous.
    pub g2: usize,
    /// Largest gap (mm).
    pub max_gap_mm: f64,
    /// Largest tangent angle among G1 and G2 joints (degrees).
    pub max_smooth_angle_deg: f64,
    /// Largest curvature jump among G2 joints (1/mm).
    pub max_g2_curvature_jump: f64,
}

/// Classifies one joint between `a` (ending) and `b` (starting).
pub fn joint(
    a: &Segment,
    b: &Segment,
    a_kind: MoveKind,
    b_kind: MoveKind,
) -> (JointClass, f64, f64, f64) {
    let gap = a.end().dist(b.start());
    if gap > GAP_TOL_MM {
        return (JointClass::Gap, gap, 0.0, 0.0);
    }
    let (ta, tb) = match (a.end_tangent(), b.start_tangent()) {
        (Some(ta), Some(tb))
            if a.start().dist(a.end()) > DEGENERATE_MM || !matches!(a, Segment::Line(_)) =>
        {
            (ta, tb)
        }
        _ => return (JointClass::Degenerate, gap, 0.0, 0.0),
    };
    if matches!(b, Segment::Line(l) if l.length() <= DEGENERATE_MM) {
        return (JointClass::Degenerate, gap, 0.0, 0.0);
    }
    let angle = ta.angle_to(tb).to_degrees();
    let ka = a.curvature_vec(1.0);
    let kb = b.curvature_vec(0.0);
    let jump = (ka - kb).norm();
    if a_kind == MoveKind::Rapid || b_kind == MoveKind::Rapid {
        return (JointClass::Rapid, gap, angle, jump);
    }
    let class = if angle > TANGENT_TOL_DEG {
        JointClass::G0
    } else if jump > CURVATURE_ABS_TOL + CURVATURE_REL_TOL * ka.norm().max(kb.norm()) {
        JointClass::G1
    } else {
        JointClass::G2
    };
    (class, gap, angle, jump)
}

/// Audits every joint of `path`; also returns the per-joint records.
pub fn continuity_joints(path: &Toolpath) -> (Continuity, Vec<Joint>) {
    let mut joints = Vec::new();
    let c = audit(path, |j| joints.push(j));
    (c, joints)
}

/// Audits every joint of `path`.
pub fn continuity(path: &Toolpath) -> Continuity {
    audit(path, |_| {})
}

/// The audit of every joint of `path`, each joint's record handed to `record`.
fn audit(path: &Toolpath, mut record: impl FnMut(Joint)) -> Continuity {
    let mut c = Continuity::default();
    let mut prev: Option<(usize, &crate::path::Move)> = None;
    let mut idx = 0usize;
    for b in &path.blocks {
        let m = match b {
            Block::Move(m) => m,
            // Motion ncsmooth cannot place: the next move starts a new path, no joint.
            Block::Event(e) if matches!(e.kind, crate::path::EventKind::Untracked { .. }) => {
                prev = None;
                continue;
            }
            Block::Event(_) => continue,
        };
        if let Some((pi, pm)) = prev {
            let (class, gap, angle, jump) = joint(&pm.segment, &m.segment, pm.kind, m.kind);
            c.joints += 1;
            c.max_gap_mm = c.max_gap_mm.max(gap);
            match class {
                JointClass::Gap => c.gaps += 1,
                JointClass::Degenerate => c.degenerate += 1,
                JointClass::Rapid => c.rapid += 1,
                JointClass::G0 => c.g0 += 1,
                JointClass::G1 => {
                    c.g1 += 1;
                    c.max_smooth_angle_deg = c.max_smooth_angle_deg.max(angle);
                }
                JointClass::G2 => {
                    c.g2 += 1;
                    c.max_smooth_angle_deg = c.max_smooth_angle_deg.max(angle);
                    c.max_g2_curvature_jump = c.max_g2_curvature_jump.max(jump);
                }
            }
            record(Joint {
                move_index: pi,
                line: m.line,
                at: m.segment.start(),
                gap_mm: gap,
                angle_deg: angle,
                curvature_jump: jump,
                class,
            });
        }
        prev = Some((idx, m));
        idx += 1;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Arc, CubicBez, Line};
    use crate::path::Move;

    #[test]
    fn classifies_joints() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        // Line into a tangent arc: G1 (curvature 0 -> 1/10).
        tp.push_move(Move::feed(
            Line::new(Vec3::new(0.0, -10.0, 0.0), Vec3::new(10.0, -10.0, 0.0)),
            None,
            1,
        ));
        let arc = Arc::from_center(
            Vec3::new(10.0, -10.0, 0.0),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::Z,
            true,
            0,
        )
        .unwrap();
        tp.push_move(Move::feed(arc, None, 2));
        // Arc into a tangent line: G1; then a corner: G0.
        tp.push_move(Move::feed(
            Line::new(Vec3::new(20.0, 0.0, 0.0), Vec3::new(20.0, 5.0, 0.0)),
            None,
            3,
        ));
        tp.push_move(Move::feed(
            Line::new(Vec3::new(20.0, 5.0, 0.0), Vec3::new(25.0, 5.0, 0.0)),
            None,
            4,
        ));
        // Line into a Bézier with collinear first controls (zero end curvature): G2.
        let c = CubicBez::new(
            Vec3::new(25.0, 5.0, 0.0),
            Vec3::new(26.0, 5.0, 0.0),
            Vec3::new(27.0, 5.0, 0.0),
            Vec3::new(28.0, 6.0, 0.0),
        );
        tp.push_move(Move::feed(c, None, 5));
        // Gap.
        tp.push_move(Move::feed(
            Line::new(Vec3::new(30.0, 6.0, 0.0), Vec3::new(31.0, 6.0, 0.0)),
            None,
            6,
        ));
        // Rapid.
        tp.push_move(Move::rapid(
            Line::new(Vec3::new(31.0, 6.0, 0.0), Vec3::new(31.0, 6.0, 5.0)),
            7,
        ));
        let (c, j) = continuity_joints(&tp);
        let classes: Vec<JointClass> = j.iter().map(|j| j.class).collect();
        use JointClass::*;
        assert_eq!(classes, vec![G1, G1, G0, G2, Gap, Rapid]);
        assert_eq!((c.g0, c.g1, c.g2, c.gaps, c.rapid), (1, 2, 1, 1, 1));
        assert!((j[2].angle_deg - 90.0).abs() < 1e-9);
        assert!((j[0].curvature_jump - 0.1).abs() < 1e-12);
    }
}
