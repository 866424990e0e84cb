use super::*;

/// Chords of a circle of radius `r_mm` turning by `step` rad each, from angle 0.
fn circle_chords(r_mm: f64, step: f64, n: usize) -> (Vec3, Vec<Vec3>) {
    let at = |k: usize| {
        let a = step * k as f64;
        Vec3::new(r_mm * a.cos(), r_mm * a.sin(), 0.0)
    };
    (at(0), (1..=n).map(at).collect())
}

/// The schedule of these tests: `P` 0.001 mm, 500 mm/s^2, 50 mm/s at most.
fn schedule() -> BlendSchedule {
    BlendSchedule {
        p_mm: 0.001,
        q_mm: 0.0,
        acc_mm_s2: 500.0,
        feed_max_mm_s: 50.0,
    }
}

#[test]
fn blend_schedule_gives_curves_the_share_their_feed_needs() {
    let s = schedule();
    // 50 mm/s needs a radius of 2500 / 433 = 5.77 mm. At a turn of 0.01 rad that
    // blend takes 5.77 tan(0.005) = 0.029 mm of each 0.4 mm chord, which a P of
    // 0.029 tan(0.0025) = 7.2e-5 mm allows: 0.072 of P, rounded up to 2^(-15/4) =
    // 0.0743. The run's ends keep all of P (a move may join there).
    let (start, pts) = circle_chords(40.0, 0.01, 20);
    let shares = s.shares(start, &pts, Some(100.0), RunEnds::default());
    assert_eq!(shares.len(), 20);
    assert_eq!((shares[0], shares[19]), (1.0, 1.0));
    let at_feed = 2f64.powf(-15.0 / 4.0);
    assert!(shares[1..19].iter().all(|&x| x == at_feed), "{shares:?}");
    // 0.08 mm chords, which LinuxCNC's blends consume at 50 mm/s, get what their
    // speed needs too, not all of P.
    let (start, pts) = circle_chords(40.0, 0.002, 20);
    let short = s.shares(start, &pts, Some(50.0), RunEnds::default());
    assert!(short[1..19].iter().all(|&x| x < 0.5), "{short:?}");
    // At rest at both ends (rapids), the end blocks keep only their other vertex's.
    let rapids = RunEnds {
        before: RunEnd::Rapid,
        after: RunEnd::Rapid,
    };
    let stopped = s.shares(start, &pts, Some(50.0), rapids);
    assert!(stopped[0] < 0.5 && stopped[19] < 0.5, "{stopped:?}");
    // A 5 mm circle of 0.05 mm chords needs more than it has (5.77 mm): the halves of
    // the chords bound its blends to 5 mm, which 0.0156 of P already gives, so it
    // gets the least share; with 0.5 mm chords (0.1 rad) the radius needs all of P. A
    // 1000 mm one: the least.
    let (start, pts) = circle_chords(5.0, 0.01, 20);
    let small = s.shares(start, &pts, Some(50.0), RunEnds::default());
    assert!(
        small[1..19].iter().all(|&x| x == BLEND_SCHEDULE_MIN_SHARE),
        "{small:?}"
    );
    let (start, pts) = circle_chords(5.0, 0.1, 20);
    assert!(s
        .shares(start, &pts, Some(50.0), RunEnds::default())
        .iter()
        .all(|&x| x == 1.0));
    let (start, pts) = circle_chords(1000.0, 0.001, 20);
    let least = s.shares(start, &pts, Some(50.0), RunEnds::default());
    assert!(
        least[1..19].iter().all(|&x| x == BLEND_SCHEDULE_MIN_SHARE),
        "{least:?}"
    );
    // The machine's fastest feed counts, not a slower programmed one (a feed override
    // may reach it). Without it, a slower programmed feed needs less; no feed, no
    // schedule.
    let (start, pts) = circle_chords(40.0, 0.01, 20);
    assert_eq!(
        s.shares(start, &pts, Some(10.0), RunEnds::default()),
        shares
    );
    let programmed = BlendSchedule {
        feed_max_mm_s: f64::INFINITY,
        ..s
    };
    let slow = programmed.shares(start, &pts, Some(10.0), RunEnds::default());
    assert!(
        slow[2..18].iter().all(|&x| x == BLEND_SCHEDULE_MIN_SHARE),
        "{slow:?}"
    );
    assert!(programmed
        .shares(start, &pts, None, RunEnds::default())
        .is_empty());
}

/// 0.4 mm chords turning 0.01 rad each (a 40 mm radius), `n` before and `n` after a
/// 90 degree corner.
fn chords_with_a_corner(n: usize) -> (Vec3, Vec<Vec3>) {
    let mut heading = 0.0_f64;
    let mut p = Vec3::new(0.0, 0.0, 0.0);
    let mut pts = Vec::new();
    for k in 0..2 * n {
        if k == n {
            heading += std::f64::consts::FRAC_PI_2;
        }
        p += Vec3::new(heading.cos(), heading.sin(), 0.0) * 0.4;
        pts.push(p);
        heading += 0.01;
    }
    (Vec3::new(0.0, 0.0, 0.0), pts)
}

#[test]
fn blend_schedule_leaves_lines_where_linuxcnc_brakes_for_a_corner() {
    let s = schedule();
    let (start, pts) = chords_with_a_corner(40);
    let shares = s.shares(start, &pts, Some(50.0), RunEnds::default());
    assert_eq!(shares.len(), 80);
    // The corner (a 0.25 mm radius at most: 10.4 mm/s) keeps all of P on both its
    // blocks.
    assert_eq!(&shares[39..41], &[1.0, 1.0], "{shares:?}");
    // Braking for it, and leaving it, the speed is below what the 40 mm radius needs
    // at 50 mm/s (sqrt(10.4^2 + 2 a s): 22.7 mm/s one chord away, 50 mm/s from
    // 2.4 mm on). The blocks there get less P than the feed alone would give them
    // (0.0743), the least next to the corner, and keep their lines: a 0.4 mm chord
    // of which the corner's blend takes at most half leaves more than 4 ms at
    // 22.7 mm/s.
    let at_feed = 2f64.powf(-15.0 / 4.0);
    assert_eq!(shares[38], BLEND_SCHEDULE_MIN_SHARE, "{shares:?}");
    assert_eq!(shares[41], BLEND_SCHEDULE_MIN_SHARE, "{shares:?}");
    assert!(shares[36..38].iter().all(|&x| x < at_feed), "{shares:?}");
    assert!(shares[42..44].iter().all(|&x| x < at_feed), "{shares:?}");
    assert!(shares[2..30].iter().all(|&x| x == at_feed), "{shares:?}");
    assert!(shares[50..78].iter().all(|&x| x == at_feed), "{shares:?}");
    // The shares fall towards the corner and rise after it.
    assert!(
        shares[30..39].windows(2).all(|w| w[0] >= w[1]),
        "{shares:?}"
    );
    assert!(
        shares[41..50].windows(2).all(|w| w[0] <= w[1]),
        "{shares:?}"
    );
}

/// Blocks of `len` mm turning by 60 degrees and by half a degree in turn (the vertex
/// ending block k turns by 60 degrees for even k).
fn sharp_and_gentle(len: f64) -> (Vec3, Vec<Vec3>) {
    let mut heading = 0.3_f64;
    let mut p = Vec3::new(0.0, 0.0, 0.0);
    let mut pts = Vec::new();
    for k in 0..8 {
        p += Vec3::new(heading.cos(), heading.sin(), 0.0) * len;
        pts.push(p);
        heading += if k % 2 == 0 { 60f64 } else { 0.5 }.to_radians();
    }
    (Vec3::new(0.0, 0.0, 0.0), pts)
}

#[test]
fn blend_schedule_splits_a_block_for_a_vertex_that_needs_less_than_its_blocks() {
    let s = schedule();
    let (start, pts) = sharp_and_gentle(2.0);
    let plan = s.plan(start, &pts, Some(50.0), RunEnds::default()).unwrap();
    // The 60 degree corners need all of P (a 0.0065 mm radius at most: 1.7 mm/s),
    // so every block has all of it; the half-degree vertices between them, reached at
    // 45 mm/s from 2 mm away, need less than 1/16 (a 4.6 mm radius: P 4.4e-5 mm).
    assert!(plan.block.iter().all(|&x| x == 1.0), "{:?}", plan.block);
    let splits = s.splits(&plan, start, &pts, &plan.block, |p| p);
    let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
    for (j, split) in splits.iter().enumerate() {
        // Block j + 1 is cut at its front for the gentle vertex j ending block j.
        if j % 2 == 1 || j == 0 {
            assert_eq!(*split, None, "{j}");
            continue;
        }
        let split = split.unwrap_or_else(|| panic!("block {j} not split"));
        assert_eq!(split.shares, (BLEND_SCHEDULE_MIN_SHARE, 1.0), "{j}");
        // On the block's line, with room for both blends: the gentle one's at 1/16
        // of P takes 0.029 mm of each line, the corner's 0.0037 mm and 4 ms of line
        // at its speed.
        let (a, b) = (at(j), pts[j]);
        let (x, y) = ((split.point - a).norm(), (b - split.point).norm());
        assert!((x + y - (b - a).norm()).abs() < 1e-12, "{j}: off the line");
        assert!(x > 2.0 * 0.029 && y > 0.0037 + 0.004 * 1.7, "{j}: {x} {y}");
    }
    // On a grid far coarser than the lines' kink allows, none.
    let coarse = |p: Vec3| Vec3::new((p.x * 20.0).round(), (p.y * 20.0).round(), 0.0) / 20.0;
    let splits = s.splits(&plan, start, &pts, &plan.block, coarse);
    assert!(splits.iter().all(Option::is_none), "{splits:?}");
    // Nor where a block is too short for the blends at both its ends.
    let (start, pts) = sharp_and_gentle(0.05);
    let plan = s.plan(start, &pts, Some(50.0), RunEnds::default()).unwrap();
    let splits = s.splits(&plan, start, &pts, &plan.block, |p| p);
    assert!(
        splits.iter().all(Option::is_none),
        "{splits:?} {:?}",
        plan.vertex
    );
}

#[test]
fn blend_schedule_starts_a_run_from_where_the_machine_is() {
    let s = schedule();
    // 0.4 mm chords of a 40 mm radius (0.0743 of P at 50 mm/s, see above). From
    // rest the machine is at sqrt(2 a s) = 20 mm/s one chord in, 28 two chords in,
    // and needs less than the feed's share there; from 2.5 mm on it is at feed.
    let (start, pts) = circle_chords(40.0, 0.01, 40);
    let ends = |before, after| RunEnds { before, after };
    let free = s.shares(start, &pts, Some(50.0), RunEnds::default());
    let rest = s.shares(start, &pts, Some(50.0), ends(RunEnd::Rest, RunEnd::Rest));
    let at_feed = 2f64.powf(-15.0 / 4.0);
    assert_eq!(free[2], at_feed, "{free:?}");
    assert!(rest[2] < at_feed && rest[37] < at_feed, "{rest:?}");
    assert_eq!(&rest[10..30], &free[10..30]);
    // No blend at a stop: the end blocks carry only their other vertex's share.
    assert_eq!((rest[0], rest[39]), (rest[1], rest[38]), "{rest:?}");
    // A move joining along the first chord bounds nothing; one at right angles (a
    // plunge) bounds the speed like a stop does, nearly.
    let along = pts[0] - start;
    let joined = s.shares(
        start,
        &pts,
        Some(50.0),
        ends(RunEnd::Joins(along.normalized().unwrap()), RunEnd::Free),
    );
    assert_eq!(joined, free);
    let plunge = Vec3::new(0.0, 0.0, -1.0);
    let plunged = s.shares(
        start,
        &pts,
        Some(50.0),
        ends(RunEnd::Joins(plunge), RunEnd::Free),
    );
    assert!(plunged[2] < at_feed && plunged[2] >= rest[2], "{plunged:?}");
}

#[test]
fn a_point_gets_what_the_lines_beside_it_leave_of_the_tolerance() {
    let c = crate::controller::linuxcnc::CornerBlend {
        total_mm: 0.0099,
        max_p_mm: 0.0095,
    };
    let v = |x: f64, y: f64| Vec3::new(x, y, 0.0);
    let start = v(0.0, 0.0);
    let pts = [v(1.0, 0.0), v(1.0, 1.0), v(2.0, 1.0)];
    let room = |line_dev: &dyn Fn(Vec3, Vec3) -> f64, gap: f64| {
        vertex_room(0, start, &pts, false, c, line_dev, |_, _| gap).p_mm
    };
    let close = |x: f64, want: f64| assert!((x - want).abs() < 1e-12, "{x} against {want}");
    // On the program: the cap.
    close(room(&|_, _| 0.0, 0.0), 0.0095);
    // (a): the lines within reach stray 0.004 mm: 0.0099 - 0.004.
    close(room(&|_, _| 0.004, 0.0), 0.0059);
    // (b): a programmed vertex 0.006 mm from them leaves 0.0039.
    close(room(&|_, _| 0.001, 0.006), 0.0039);
    // Out of reach of the program: no room at all.
    assert!(room(&|_, _| f64::INFINITY, 0.0) < 0.0);
    // The parts of the lines measured are those within reach of the point: at a
    // right angle, what P = 0.0095 takes, P / tan(pi / 8) of each.
    let reach = 0.0095 / (std::f64::consts::PI / 8.0).tan();
    let seen = std::cell::RefCell::new(Vec::new());
    let line_dev = |a: Vec3, b: Vec3| {
        seen.borrow_mut().push(a.dist(b));
        0.0
    };
    vertex_room(0, start, &pts, false, c, line_dev, |_, _| 0.0);
    for len in seen.borrow().iter() {
        assert!((len - reach).abs() < 1e-12, "{len} against {reach}");
    }
    // Never more than half a line.
    let short = [v(0.01, 0.0), v(0.01, 1.0), v(2.0, 1.0)];
    seen.borrow_mut().clear();
    vertex_room(0, start, &short, true, c, line_dev, |_, _| 0.0);
    assert!(
        (seen.borrow()[0] - 0.005).abs() < 1e-12,
        "{:?}",
        seen.borrow()
    );
}

/// The share of `P` LinuxCNC blends point `k` with: the smaller of its two blocks'.
fn blended(block: &[f64], k: usize) -> f64 {
    block[k].min(block[k + 1])
}

#[test]
fn a_sharp_point_gets_its_room_and_its_neighbours_keep_theirs() {
    let run = 0.004;
    let room = |p_mm: f64, corner: bool| Some(VertexRoom { p_mm, corner });
    let free = RunEnds::default();
    // Points 1 and 3 need all of the run's P (3 mm/s and 5 mm/s); point 2 between
    // them has no room beyond the run's.
    let rooms = [
        room(0.0095, false),
        room(0.0095, false),
        room(0.004, false),
        room(0.0095, false),
        room(0.0095, false),
    ];
    let speeds = [None, Some(3.0), None, Some(5.0), None];
    let mut block = vec![1.0; 6];
    raise_for_rooms(&mut block, &rooms, run, free, |k| speeds[k]);
    // The slower point takes its room; the other would give point 2 more than its
    // own, and keeps the run's P.
    assert_eq!(block, vec![1.0, 2.375, 2.375, 1.0, 1.0, 1.0]);
    assert_eq!(blended(&block, 2), 1.0);
    // The other way round, the other one.
    let speeds = [None, Some(5.0), None, Some(3.0), None];
    let mut block = vec![1.0; 6];
    raise_for_rooms(&mut block, &rooms, run, free, |k| speeds[k]);
    assert_eq!(block, vec![1.0, 1.0, 1.0, 2.375, 2.375, 1.0]);
    // A point that does not need all of P, or has no more room than the run's P,
    // is left as it is.
    let mut block = vec![1.0; 6];
    raise_for_rooms(&mut block, &rooms, run, free, |_| None);
    assert_eq!(block, vec![1.0; 6]);
}

#[test]
fn an_empty_chain_has_nothing_to_raise() {
    let mut block: Vec<f64> = Vec::new();
    raise_for_rooms(&mut block, &[], 0.004, RunEnds::default(), |_| Some(1.0));
    assert!(block.is_empty());
    assert_eq!(raised_span(0, RunEnds::default()), (1, 0));
}

#[test]
fn a_chain_end_is_raised_only_next_to_a_stop() {
    let run = 0.004;
    let rooms = [Some(VertexRoom {
        p_mm: 0.008,
        corner: false,
    }); 2];
    let sharp = |_: usize| Some(3.0);
    // Point 0 joins blocks 0 and 1: block 0 starts at the chain's start, where the
    // move before it has a P of its own; point 1 joins blocks 1 and 2, which ends it.
    let mut block = vec![1.0; 3];
    raise_for_rooms(&mut block, &rooms, run, RunEnds::default(), sharp);
    assert_eq!(block, vec![1.0; 3]);
    // Next to a rapid (LinuxCNC stops there): raised.
    let rest = RunEnds {
        before: RunEnd::Rest,
        after: RunEnd::Rest,
    };
    let mut block = vec![1.0; 3];
    raise_for_rooms(&mut block, &rooms, run, rest, sharp);
    assert_eq!(block, vec![2.0; 3]);
    // A programmed corner put in place of short blocks is raised wherever it is.
    let corners = [Some(VertexRoom {
        p_mm: 0.008,
        corner: true,
    }); 2];
    let mut block = vec![1.0; 3];
    raise_for_rooms(&mut block, &corners[..1], run, RunEnds::default(), |_| None);
    assert_eq!(block, vec![2.0, 2.0, 1.0]);
}

proptest::proptest! {
    /// Whatever the rooms, shares and order, no point is blended with more than the
    /// larger of its room and what the schedule gave it, and no share goes down.
    #[test]
    fn raises_keep_every_point_within_its_room(
        rooms in proptest::collection::vec(
            proptest::option::of((0.0..0.01f64, proptest::bool::ANY)),
            1..12,
        ),
        shares in proptest::collection::vec(0.0625..1.0f64, 13),
        speeds in proptest::collection::vec(proptest::option::of(0.0..50.0f64), 12),
    ) {
        let run = 0.004;
        let rooms: Vec<Option<VertexRoom>> = rooms
            .into_iter()
            .map(|r| r.map(|(p_mm, corner)| VertexRoom { p_mm, corner }))
            .collect();
        let before: Vec<f64> = shares[..rooms.len() + 1].to_vec();
        let mut block = before.clone();
        let rest = RunEnds { before: RunEnd::Rest, after: RunEnd::Rest };
        raise_for_rooms(&mut block, &rooms, run, rest, |k| speeds[k]);
        for k in 0..rooms.len() {
            let room = rooms[k].map_or(0.0, |r| r.p_mm / run);
            let lim = room.max(blended(&before, k));
            proptest::prop_assert!(blended(&block, k) <= lim + 1e-12, "{k}: {block:?}");
        }
        for (b, a) in block.iter().zip(&before) {
            proptest::prop_assert!(b >= a);
        }
    }
}

#[test]
fn blend_schedule_accelerates_at_half_the_rate_on_what_its_blends_consume() {
    let s = schedule();
    // 0.2 mm chords turning 0.04 rad (a 5 mm radius), from rest to rest. Taking the
    // full acceleration along every block, the first pass has the machine faster
    // than it is: LinuxCNC accelerates at half the rate on what its blends take, and
    // the passes that follow find it slower there, so those vertices need less of P.
    let (start, pts) = circle_chords(5.0, 0.04, 30);
    let rest = RunEnds {
        before: RunEnd::Rest,
        after: RunEnd::Rest,
    };
    let first = s.plan_in(start, &pts, Some(50.0), rest, 1).unwrap();
    let settled = s.plan(start, &pts, Some(50.0), rest).unwrap();
    let pairs = || settled.speed.iter().zip(&first.speed);
    assert!(pairs().all(|(a, b)| a <= b), "{:?}", settled.speed);
    assert!(pairs().any(|(a, b)| a < &(0.9 * b)), "{:?}", settled.speed);
    assert!(settled.block.iter().zip(&first.block).all(|(a, b)| a <= b));
    assert!(settled.block.iter().zip(&first.block).any(|(a, b)| a < b));
}

proptest::proptest! {
    /// Whatever the lines (repeated points, reversals, tiny and long blocks), every
    /// block gets a share of `P` in `[BLEND_SCHEDULE_MIN_SHARE, 1]`, never more than
    /// the run's `P` (the tolerance budget), and the run's end blocks get all of it
    /// unless the machine is at rest there.
    #[test]
    fn blend_schedule_shares_stay_within_the_runs_p(
        pts in proptest::collection::vec(
            (-2.0f64..2.0, -2.0f64..2.0, proptest::prelude::any::<bool>()), 1..60),
        acc in 10.0f64..5000.0,
        feed in 1.0f64..200.0,
        fastest in proptest::prelude::any::<bool>(),
        ends in 0u8..9,
    ) {
        let s = BlendSchedule {
            p_mm: 0.001,
            q_mm: 0.0,
            acc_mm_s2: acc,
            feed_max_mm_s: if fastest { feed } else { f64::INFINITY },
        };
        // Some points repeat the one before.
        let mut line = Vec::new();
        let mut last = Vec3::new(0.0, 0.0, 0.0);
        for (x, y, repeat) in pts {
            if !repeat {
                last = Vec3::new(x, y, 0.0);
            }
            line.push(last);
        }
        let end = |k: u8| match k {
            0 => RunEnd::Free,
            1 => RunEnd::Rest,
            _ => RunEnd::Joins(Vec3::new(1.0, -1.0, 0.5).normalized().unwrap()),
        };
        let ends = RunEnds { before: end(ends % 3), after: end(ends / 3) };
        let shares = s.shares(Vec3::new(0.0, 0.0, 0.0), &line, Some(feed), ends);
        proptest::prop_assert_eq!(shares.len(), line.len());
        for &x in &shares {
            proptest::prop_assert!((BLEND_SCHEDULE_MIN_SHARE..=1.0).contains(&x), "{:?}", shares);
        }
        // All of `P` at an end where a move may join (none blends with a stop).
        if !ends.before.at_rest() {
            proptest::prop_assert_eq!(shares[0], 1.0);
        }
        if !ends.after.at_rest() {
            proptest::prop_assert_eq!(shares[shares.len() - 1], 1.0);
        }
    }
}

#[test]
fn vertex_blend_is_linuxcncs_blend_geometry() {
    // blendmath.c: theta is half the angle between the lines, pi/2 - phi/2; the blend
    // takes d_tol = cos(theta) P / (1 - sin(theta)) of each line, at most half of the
    // shorter one, and has radius tan(theta) d.
    let p = 0.001;
    for phi in [0.002_f64, 0.01, 0.3, 1.0, 2.0, 3.0] {
        let u = Vec3::new(0.4, 0.0, 0.0);
        let w = Vec3::new(phi.cos(), phi.sin(), 0.0) * 0.3;
        let b = VertexBlend::new(u, w, 1e-3);
        let theta = 0.5 * (std::f64::consts::PI - phi);
        let d = (theta.cos() * p / (1.0 - theta.sin())).min(0.15);
        let rel = |x: f64, y: f64| ((x - y) / y).abs();
        assert!(rel(b.reach_mm(p), d) < 1e-9, "{phi}");
        assert!(rel(b.radius_mm(p), theta.tan() * d) < 1e-9, "{phi}");
        // The least P for a radius gives that radius, or all the lines allow.
        for r in [0.01, 1.0, 100.0] {
            let q = b.p_for_radius_mm(r);
            assert!(
                rel(b.radius_mm(q), r.min(b.radius_mm(1e9))) < 1e-9,
                "{phi} {r}"
            );
        }
    }
    // Below the tangent kink, LinuxCNC joins without a blend: nothing taken.
    let b = VertexBlend::new(Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 5e-4, 0.0), 1e-3);
    assert_eq!(b.reach_mm(p), 0.0);
}
