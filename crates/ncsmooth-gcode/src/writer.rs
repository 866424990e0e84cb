//! G-code writer: [`Toolpath`] to RS274/NGC text that this crate's parser, LinuxCNC and
//! grbl read back as the same motion.
//!
//! Output format:
//!
//! * Optional header comment lines, then `G21 G90 G94 G17`: millimetres, absolute
//!   coordinates, units-per-minute feed, XY plane; arc centres are incremental I/J/K (the
//!   G91.1 default; `G91.1` itself is not written because grbl does not know it).
//! * Lines as `G0`/`G1`. The motion word is written on every line; axis words only when
//!   their formatted value changes (at least one axis is always written). `F` (mm/min) is
//!   written when its formatted value changes.
//! * Arcs whose normal is ±Z, ±Y or ±X (within 1e-9) as `G2`/`G3` in G17/G18/G19 (the
//!   plane word is written when it changes), with both in-plane end coordinates, the axial
//!   coordinate for helices, both centre offsets, and `P` for multi-turn arcs. Centre
//!   offsets are taken from the *written* (rounded) start point and written with
//!   [`CENTRE_EXTRA_DECIMALS`] more digits than the coordinates, so the centre the reader
//!   computes is essentially exact. Arcs in other planes, arcs whose
//!   radius is under two units of the last decimal, and arcs that rounding would turn into
//!   a full circle are flattened to `G1` lines within `chord_mm` with
//!   [`Flatten`]. So are all non-native segments (Béziers,
//!   NURBS and any future kind); extra axes are interpolated along the pieces by length.
//! * Events are written as their text, in order. An `M83` event is written as `M82`
//!   (with a comment) because the writer always writes absolute E. After an event, extra
//!   axes are rewritten on the next move (`G92 E0` may have reset them) and after an event
//!   with an `F` word the feed is rewritten.
//! * [`EventKind::Untracked`] events (a G53 move,
//!   a G28 return, a move from an unknown position) are written as their text (the
//!   programmed block); the next move writes all its axes.
//!
//! The same motion writer (`MotionWriter`) serves [`crate::rewrite()`], which writes in
//! the program's own units and modes and never writes an axis whose position is unknown.
//!
//! Numbers use `decimals` digits after the point (default 4), trailing zeros removed,
//! never exponent notation and never `-0`. With 4 decimals the rounding is up to 5e-5 mm;
//! a round trip that must agree to 1e-6 mm needs 6 or more decimals (the round-trip
//! property test uses 6). Fewer than 3 decimals can make a reader reject arcs whose
//! rounded radii differ by more than its tolerance.

use crate::chain_extra::ExtraProfile;
use ncsmooth::decimal::POW10_U64;
use ncsmooth::geom::{Arc, CubicBez, Flatten, Nurbs, ParamCurve, Segment, Vec3};
use ncsmooth::path::{Block, EventKind, Move, MoveKind, Toolpath, EXTRA_AXIS_NAMES};
use std::f64::consts::TAU;
use std::fmt::{self, Write as _};

/// The bit of `E` (a printer's extrusion) in [`Frame::extra_mask`].
const E_AXIS_BIT: u8 = 1 << ncsmooth::path::E_AXIS;

/// Digits `E` gets beyond the coordinates' (5 at the default 4, as slicers write it): a
/// block of a smoothed print extrudes a few thousandths of a millimetre of filament, and
/// rounding that to 4 decimals changed each block's flow by up to a few per cent.
pub const E_EXTRA_DECIMALS: usize = 1;

/// Most digits after the point the writer prints; more are clamped to this. 1e-12 mm is
/// below what an f64 coordinate of a few metres resolves.
pub const MAX_DECIMALS: usize = 12;

/// Most digits [`push_fixed`] prints: coordinates at [`MAX_DECIMALS`] plus the extra
/// digits of arc centres.
pub const PRINT_DECIMALS_MAX: usize = MAX_DECIMALS + CENTRE_EXTRA_DECIMALS;

/// Largest distance (mm) a point moves when each coordinate is rounded to `decimals`
/// digits (half a unit of the last digit on each of the three axes).
pub fn rounding_mm(decimals: usize) -> f64 {
    0.5 * 0.1f64.powi(decimals.min(MAX_DECIMALS) as i32) * 3f64.sqrt()
}

/// Writer settings.
#[derive(Clone, Debug, PartialEq)]
pub struct WriteOptions {
    /// Digits after the decimal point (default 4; at most [`MAX_DECIMALS`]).
    pub decimals: usize,
    /// Prefix every block with `N<k>` (default false).
    pub line_numbers: bool,
    /// Comment written at the top, one `( )` line per text line (parentheses in it are
    /// replaced by brackets).
    pub header: Option<String>,
    /// Chord tolerance (mm) for flattening curves and off-axis arcs (default 0.001).
    pub chord_mm: f64,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            decimals: 4,
            line_numbers: false,
            header: None,
            chord_mm: 0.001,
        }
    }
}

/// Appends `v` with at most `decimals` digits after the point, without trailing zeros,
/// never `-0` and never in exponent notation.
///
/// Fast path (the writer formats millions of numbers, and `{:.N}` falls back to exact
/// big-number arithmetic for most of them): when `|v| 10^decimals < 9e15`, the value is
/// scaled, rounded half away from zero to an integer and printed with the point
/// inserted. The scaling itself rounds, so a value within one ulp of a tie may round
/// the other way than exact decimal rounding would: the printed value is still within
/// half a unit of the last digit (plus an ulp) of `v`. Other values use `{:.N}`.
/// `decimals` is clamped to [`PRINT_DECIMALS_MAX`].
pub fn push_fixed(s: &mut String, v: f64, decimals: usize) {
    let decimals = decimals.min(PRINT_DECIMALS_MAX);
    if decimals < POW10_U64.len() && v.is_finite() {
        let p = POW10_U64[decimals];
        let x = (v * p as f64).round();
        if x.abs() < 9.0e15 {
            let r = x as i64;
            if r == 0 {
                s.push('0');
                return;
            }
            if r < 0 {
                s.push('-');
            }
            let u = r.unsigned_abs();
            let (int, mut frac) = (u / p, u % p);
            let _ = write!(s, "{int}");
            if frac != 0 {
                let mut width = decimals;
                while frac % 10 == 0 {
                    frac /= 10;
                    width -= 1;
                }
                let _ = write!(s, ".{frac:0width$}");
            }
            return;
        }
    }
    let start = s.len();
    let _ = write!(s, "{:.*}", decimals, v);
    if s[start..].contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if &s[start..] == "-0" {
        s.truncate(start);
        s.push('0');
    }
}

/// Writes `tp` as G-code text.
pub fn write(tp: &Toolpath, opts: &WriteOptions) -> String {
    let mut s = String::with_capacity(tp.blocks.len() * 32 + 64);
    // Writing into a String cannot fail.
    let _ = write_to(tp, opts, &mut s);
    s
}

/// Writes `tp` as G-code text into `out`.
pub fn write_to<W: fmt::Write>(tp: &Toolpath, opts: &WriteOptions, out: &mut W) -> fmt::Result {
    if let Some(h) = &opts.header {
        for l in h.lines() {
            let l: String = l
                .chars()
                .map(|c| match c {
                    '(' => '[',
                    ')' => ']',
                    c => c,
                })
                .collect();
            writeln!(out, "({l})")?;
        }
    }
    let mut w = MotionWriter::new(
        Frame {
            decimals: opts.decimals.min(MAX_DECIMALS),
            chord_mm: opts.chord_mm,
            extra_mask: tp.extra_axes_mask,
            ..Frame::default()
        },
        tp.start,
    );
    w.line_numbers = opts.line_numbers;
    w.begin();
    w.line.push_str("G21 G90 G94 G17");
    w.end(out)?;
    for b in &tp.blocks {
        match b {
            Block::Event(e) => {
                w.begin();
                match e.kind {
                    EventKind::Comment => push_comment(&mut w.line, "", &e.text),
                    EventKind::Message => push_comment(&mut w.line, "MSG,", &e.text),
                    // Everything here is written in mm.
                    EventKind::Units(_) => push_comment(&mut w.line, "source units ", &e.text),
                    _ if e.text.trim() == "M83" => w
                        .line
                        .push_str("M82 (M83 in the source: the writer writes absolute E)"),
                    _ => w.line.push_str(&e.text),
                }
                w.end(out)?;
                w.forget_extras();
                if e.text.contains('F') {
                    w.forget_feed();
                }
                if matches!(e.kind, EventKind::Untracked { .. }) {
                    w.forget_axes();
                }
            }
            Block::Move(m) => w.write_move(m, out)?,
        }
    }
    Ok(())
}

/// Appends `(prefix text)`, with parentheses inside replaced by brackets.
fn push_comment(line: &mut String, prefix: &str, text: &str) {
    line.push('(');
    line.push_str(prefix);
    line.extend(text.chars().map(|c| match c {
        '(' => '[',
        ')' => ']',
        c => c,
    }));
    line.push(')');
}

/// How runs of feed moves are written under a long-block emitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ChainMode {
    /// Shortest last block to aim for (mm).
    pub min_block_mm: f64,
    /// ... or this many seconds of the run's feed.
    pub min_block_s: f64,
    /// Fit XY arcs (G2/G3) as well as lines.
    pub arcs: bool,
    /// Arcs that would take [`NATIVE_ARC_MIN_BLOCKS`] chords stay `G2`/`G3` and end the
    /// chain; `false` flattens those next to a flattened curve with the rest
    /// ([`crate::Dialect::keeps_long_arcs`], [`MotionWriter::chainable_at`]).
    pub long_arcs: bool,
}

/// The programmed path of the moves being written and the tolerance left for the written
/// blocks against it: blocks shorter than `min_block_mm` are lifted where the program
/// allows ([`crate::chain::lift_short_blocks`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Floor {
    /// The programmed path as a polyline (mm).
    pub program: Vec<Vec3>,
    /// Two-sided tolerance (mm) of the written blocks against `program`.
    pub tol_mm: f64,
    /// Shortest block the controller should be given (mm).
    pub min_block_mm: f64,
    /// The grid over `program`, built when a first short block needs it.
    pub grid: std::cell::OnceCell<crate::chain::SegGrid>,
    /// LinuxCNC: short blocks are lifted only to the programmed corner, which gets a `P`
    /// of its own.
    pub corner: Option<crate::rewrite::CornerBlend>,
}

impl Floor {
    /// The programmed path as the block floor's [`crate::chain::Program`].
    fn program_ref(&self) -> crate::chain::Program<'_> {
        crate::chain::Program {
            points: &self.program,
            tol_mm: self.tol_mm,
        }
    }

    /// The room of each point of the chain from `start` through `pts` (not the last) that
    /// is `wanted` or a programmed corner put in place of short blocks (`snapped`), under
    /// LinuxCNC ([`vertex_room`]); `None` for the others, and for all without
    /// [`Floor::corner`].
    fn rooms(
        &self,
        start: Vec3,
        pts: &[Vec3],
        snapped: &[Vec3],
        wanted: &[bool],
    ) -> Vec<Option<VertexRoom>> {
        let Some(c) = self.corner else {
            return Vec::new();
        };
        let program = self.program_ref();
        let grid = self.grid.get_or_init(|| program.grid());
        let line_dev = |a: Vec3, b: Vec3| program.max_dist_near(grid, a, b, ROOM_SAMPLES);
        let gap = |lines: &[(Vec3, Vec3)], others: &[(Vec3, Vec3)]| {
            program.vertex_gap(grid, lines, others, c.total_mm)
        };
        (0..pts.len().saturating_sub(1))
            .map(|k| {
                let corner = snapped.contains(&pts[k]);
                (corner || wanted.get(k) == Some(&true))
                    .then(|| vertex_room(k, start, pts, corner, c, line_dev, gap))
            })
            .collect()
    }
}

/// How a [`MotionWriter`] writes: units, modes and which axes it may write.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Frame {
    /// Coordinate decimals.
    pub decimals: usize,
    /// Flattening chord (mm).
    pub chord_mm: f64,
    /// Millimetres per written unit (1 or 25.4).
    pub scale: f64,
    /// Bit `i` set when X/Y/Z `i` may be written (its position is known).
    pub allowed_xyz: u8,
    /// Arc centres as absolute coordinates (G90.1) rather than offsets.
    pub arc_absolute: bool,
    /// E words relative (M83).
    pub e_relative: bool,
    /// G7: X is written as a diameter.
    pub diameter: bool,
    /// Plane in force (17, 18, 19).
    pub plane: u8,
    /// Extra axes in use (bit per [`EXTRA_AXIS_NAMES`]).
    pub extra_mask: u8,
    /// `Some`: runs of feed moves are written as long blocks ([`crate::chain`]); `None`:
    /// move by move.
    pub chain: Option<ChainMode>,
    /// Planes for `G2`/`G3` (bit 0 G17, bit 1 G18, bit 2 G19).
    pub arc_planes: u8,
    /// Spiral arcs (end radius off the start radius) are written as `G2`/`G3`; when false
    /// only those within half the chord of a circle are.
    pub spiral_arcs: bool,
    /// Cubic Béziers in the XY plane are written as `G5` (exact).
    pub g5: bool,
    /// NURBS in the XY plane are written as `G5.2`/`G5.3`, one per Bézier span (exact).
    pub nurbs: bool,
}

impl Default for Frame {
    fn default() -> Self {
        Frame {
            decimals: 4,
            chord_mm: 0.001,
            scale: 1.0,
            allowed_xyz: 0b111,
            arc_absolute: false,
            e_relative: false,
            diameter: false,
            plane: 17,
            extra_mask: 0,
            chain: None,
            arc_planes: 0b111,
            spiral_arcs: true,
            g5: false,
            nurbs: false,
        }
    }
}

/// Significant digits `G64 P Q` keep at least, beyond the coordinates' decimals: rounded
/// down to the coordinates' 5 inch decimals, the default `P` of 0.001 mm (3.94e-5 in)
/// printed as `P0.00003`, a quarter of the blending given away.
const BLEND_SIGNIFICANT_DIGITS: i32 = 3;

/// Decimals that print `v` (program units, positive) with [`BLEND_SIGNIFICANT_DIGITS`]
/// significant digits, at least `decimals` and at most [`MAX_DECIMALS`].
fn blend_decimals(v: f64, decimals: usize) -> usize {
    if !(v > 0.0 && v.is_finite()) {
        return decimals;
    }
    let first_digit = (-v.log10()).ceil().max(0.0) as i32;
    let want = (first_digit + BLEND_SIGNIFICANT_DIGITS - 1).max(0) as usize;
    want.clamp(decimals, MAX_DECIMALS.max(decimals))
}

/// `G64 P Q` (or `G61` when `P` would print as 0, which LinuxCNC reads as no bound) for
/// `P = p_mm`, `Q = q_mm` in a program whose unit is `scale` mm, each value rounded down to at least `decimals` and
/// [`BLEND_SIGNIFICANT_DIGITS`] significant digits, so the bound written never exceeds
/// the one asked for.
pub(crate) fn blend_words(p_mm: f64, q_mm: f64, scale: f64, decimals: usize) -> String {
    let decimals = blend_decimals(p_mm / scale, decimals);
    let p10 = 10f64.powi(decimals as i32);
    let down = |v: f64| (v / scale * p10).floor() / p10;
    let (p, q) = (down(p_mm), down(q_mm));
    if p.is_nan() || p <= 0.0 {
        return "G61".to_string();
    }
    let mut t = String::from("G64 P");
    push_fixed(&mut t, p, decimals);
    if q > 0.0 {
        t.push_str(" Q");
        push_fixed(&mut t, q, decimals);
    } else {
        // Q0 turns the naive-CAM merging off (Q would otherwise default to P).
        t.push_str(" Q0");
    }
    t
}

/// LinuxCNC's share of the acceleration its blend arcs keep for the normal direction
/// (tp.c `BLEND_ACC_RATIO_NORMAL`, `sqrt(1 - 0.5^2)`).
pub const LINUXCNC_NORMAL_ACC_SHARE: f64 = 0.866_025_403_784_438_6;

/// LinuxCNC's share of the acceleration its arcs and blend arcs keep for the tangential
/// direction (tp.c `BLEND_ACC_RATIO_TANGENTIAL`).
pub const LINUXCNC_TANGENTIAL_ACC_SHARE: f64 = 0.5;

/// Passes of a [`BlendSchedule`]'s speed estimate: each takes the acceleration along a
/// block from the share of it the previous pass's blends take.
pub const BLEND_SCHEDULE_SPEED_PASSES: usize = 4;

/// Servo periods of straight line LinuxCNC leaves between two blend arcs; a shorter
/// remainder is consumed by the blends (tp.c `ARC_BLEND_GAP_CYCLES`).
pub const LINUXCNC_BLEND_GAP_CYCLES: f64 = 4.0;
/// [`LINUXCNC_BLEND_GAP_CYCLES`] in seconds.
const LINUXCNC_BLEND_GAP_S: f64 =
    LINUXCNC_BLEND_GAP_CYCLES * crate::dialect::LINUXCNC_SERVO_PERIOD_S;

/// LinuxCNC's default `[TRAJ] ARC_BLEND_KINK_RATIO`: the share of the axes' acceleration
/// a kink between two moves may take before they are blended rather than joined as
/// tangent (tp.c `tpGetTangentKinkRatio`).
pub const LINUXCNC_TANGENT_KINK_RATIO: f64 = 0.1;

/// Smallest share of `P` a block gets under a [`BlendSchedule`]. Measured on LinuxCNC 2.9
/// (50 mm/s, 500 mm/s^2, tol 0.01), butterfly_1000 / cncjs_jsdc nurbs: 1/8 9.348 / 18.187 s,
/// 1/16 9.325 / 18.167 s, 1/32 9.483 / 18.206 s, 1/64 9.642 / 18.316 s.
pub const BLEND_SCHEDULE_MIN_SHARE: f64 = 1.0 / 16.0;

/// Steps per halving of `P` a [`BlendSchedule`] rounds its shares up to (4: shares are
/// powers of `2^(1/4)`), trading `G64` lines for time. Measured on butterfly_1000 nurbs
/// (LinuxCNC 2.9): 1 step 9.396 s, 2 steps 9.382 s, 4 steps 9.377 s with 216 `G64`
/// lines, unrounded 9.368 s with 376.
pub const BLEND_SCHEDULE_STEPS_PER_HALVING: f64 = 4.0;

/// A block cut in two by a [`BlendSchedule`] (`BlendSchedule::splits`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Split {
    /// Where the first piece ends (on the written grid).
    point: Vec3,
    /// The two pieces' shares of `P`.
    shares: (f64, f64),
}

/// The point on the grid (`rounded`) between `a` and `b`, at least `room.0` from `a` and
/// `room.1` from `b`, whose kink (the largest axis component of the change of direction)
/// is least, if that is at most `kink_max`.
fn split_point(
    a: Vec3,
    b: Vec3,
    room: (f64, f64),
    rounded: impl Fn(Vec3) -> Vec3,
    kink_max: f64,
) -> Option<Vec3> {
    let len = (b - a).norm();
    let free = len - room.0 - room.1;
    if free.is_nan() || free <= 0.0 {
        return None;
    }
    (0..=SPLIT_CANDIDATES)
        .map(|i| {
            rounded(a + (b - a) * ((room.0 + free * i as f64 / SPLIT_CANDIDATES as f64) / len))
        })
        .filter(|&q| (q - a).norm() >= room.0 && (b - q).norm() >= room.1)
        .filter_map(|q| Some((((b - q).normalized()? - (q - a).normalized()?).max_abs(), q)))
        .filter(|&(kink, _)| kink <= kink_max)
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, q)| q)
}

/// The speed estimate and shares of a [`BlendSchedule`] for one chain.
#[derive(Clone, Debug)]
struct BlendPlan {
    /// Share of `P` per block.
    block: Vec<f64>,
    /// Share of `P` each vertex needs (at the end of block k).
    vertex: Vec<f64>,
    /// Speed estimate at each vertex (mm/s).
    speed: Vec<f64>,
    /// LinuxCNC's blend at each vertex.
    blends: Vec<VertexBlend>,
    /// The fastest feed the blends are sized for (mm/s).
    v: f64,
}

/// A [`BlendSchedule`] splits a block where that lowers a vertex's `P` by at least this
/// factor (two of its steps, [`BLEND_SCHEDULE_STEPS_PER_HALVING`]).
pub const SPLIT_MIN_GAIN: f64 = 1.41;
/// Room a split keeps on each piece over what LinuxCNC's blends need of it.
pub const SPLIT_ROOM: f64 = 1.2;
/// Largest share of the acceleration a split's kink may take (tp.c `tpSetupTangent`
/// joins two lines as tangent when the kink at full speed takes less than
/// [`LINUXCNC_TANGENT_KINK_RATIO`], and lowers both lines' acceleration by that share).
/// Measured on camotics_vcarve trig (LinuxCNC 2.9, 50 mm/s, 500 mm/s^2, tol 0.01):
/// 0.02 20.219 s, 0.05 20.214 s, within the spread of a few ms between runs.
pub const SPLIT_KINK_RATIO: f64 = 0.02;
/// Points tried along a block for a split.
pub const SPLIT_CANDIDATES: usize = 256;

/// What moves next to a run of blocks at one of its ends, for a [`BlendSchedule`]'s
/// speed estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RunEnd {
    /// Not known: the estimate takes no limit there (it errs high).
    #[default]
    Free,
    /// The machine is at rest there: the program's start or end. LinuxCNC runs the
    /// program's last segment with half the acceleration (its end condition stays the
    /// parabolic blend's, tc.c `tcGetOverallMaxAccel`).
    Rest,
    /// A rapid moves there: LinuxCNC stops between a rapid and a feed move, and the feed
    /// move before it ends with a stop, at the full acceleration (tp.c
    /// `tpCheckCanonType`).
    Rapid,
    /// A move in this unit direction (of travel) joins the run there: LinuxCNC blends
    /// that junction within the run's `P` at most, which bounds the speed.
    Joins(Vec3),
}

impl RunEnd {
    /// The machine is at rest there: the program's ends, or a rapid.
    pub fn at_rest(self) -> bool {
        matches!(self, RunEnd::Rest | RunEnd::Rapid)
    }
}

/// The two ends of a run of blocks, see [`RunEnd`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunEnds {
    /// What moves before the run's first block.
    pub before: RunEnd,
    /// What moves after its last block.
    pub after: RunEnd,
}

/// Per-block `G64 P` for LinuxCNC's blending of a flattened curve.
///
/// LinuxCNC blends two lines turning by `phi` with an arc tangent to both that takes
/// `d = min(P / tan(phi / 4), half the shorter line)` of each and has radius
/// `d / tan(phi / 2)` (`VertexBlend`, blendmath.c `blendComputeParameters`). At the
/// chords of a curve flattened within `c`, `P = c` gives about the curve's radius and
/// consumes every line, and LinuxCNC accelerates along what its blends consume with half
/// the acceleration (tc.c `tcGetTangentialMaxAccel`). A vertex whose speed `v` needs a
/// smaller radius (`v^2 / a_n`, `a_n` = [`LINUXCNC_NORMAL_ACC_SHARE`] of the
/// acceleration) gets the least `P` that gives it, and leaves LinuxCNC the rest of the
/// lines to accelerate on at the full rate.
///
/// `v` is a look-ahead estimate along the written lines: at most the machine's fastest
/// feed (or else the programmed one), at most what the blend with all of `P` allows, and
/// at most what the acceleration along the blocks reaches from the neighbouring vertices
/// (a forward and a backward pass). Along what the blends take of a block LinuxCNC
/// accelerates with [`LINUXCNC_TANGENTIAL_ACC_SHARE`] of the acceleration, the full rate
/// only on the line they leave, so the estimate is made again with the shares the last
/// one gave ([`BLEND_SCHEDULE_SPEED_PASSES`] passes at most). So the vertices where
/// LinuxCNC brakes for, or leaves, a tight turn get a small `P` as well, not only the
/// gently curved ones at full feed. A block whose blends leave less than
/// [`LINUXCNC_BLEND_GAP_CYCLES`] servo periods of line at that speed is consumed
/// (blendmath.c `blendCheckConsume`) and run at the blend's half acceleration; its
/// vertices still get only what their speed needs, the least `P` consuming the least of
/// the next blocks. (They had all of `P`, for the radius: LinuxCNC 2.9, 50 mm/s,
/// 500 mm/s^2, tol 0.01, bspline / arc / nurbs / trig, camotics_vcarve 20.099 / 20.097 /
/// 20.108 / 20.138 s -> 20.083 / 20.080 / 20.084 / 20.093 s, butterfly_1000 9.179 /
/// 9.179 / 9.153 / 9.195 -> 9.169 / 9.169 / 9.143 / 9.190 s, cncjs_jsdc 1-6 ms faster,
/// crown unchanged.) Vertices LinuxCNC joins as tangent (below
/// [`LINUXCNC_TANGENT_KINK_RATIO`]) take nothing. Shares are clamped to
/// [`BLEND_SCHEDULE_MIN_SHARE`]` ..= 1` and rounded up to a power of `2^(1/4)`
/// ([`BLEND_SCHEDULE_STEPS_PER_HALVING`]); a block gets the larger of its two vertices'
/// (a blend uses the smaller `P` of its two blocks), and the run's ends where a move
/// may join them, and the run's own `P` after the chain, get all of it. `P` is never
/// larger than the run's, so the
/// tolerance budget is unchanged (the schedule's own shares; a programmed corner put in
/// place of short blocks, and a point whose speed needs all of `P`, get more where the
/// tolerance leaves it, [`crate::rewrite::CornerBlend`], checked by the model of the
/// executed path).
///
/// A vertex between two blocks that carry more for their other vertices (a gentle turn
/// between two tight ones) gets its own share from a split of one of them
/// (`BlendSchedule::splits`): the point cutting it is on its line, a join LinuxCNC takes
/// as tangent, so the blend there leaves LinuxCNC its lines to accelerate on at the full
/// rate. LinuxCNC 2.9 (50 mm/s, 500 mm/s^2, tol 0.01), bspline / arc / nurbs / trig:
/// camotics_vcarve 20.356 / 20.379 / 20.443 / 20.332 s -> 20.255 / 20.280 / 20.343 /
/// 20.230, butterfly_1000 9.212 / 9.215 / 9.179 / 9.235 -> 9.197 / 9.186 / 9.156 / 9.221,
/// crown and cncjs_jsdc within 5 ms of before.
///
/// Measured (LinuxCNC 2.9, 50 mm/s, 500 mm/s^2, tol 0.01), butterfly_1000 nurbs: one `P`
/// 9.520 s; shares for the feed alone, with the radius estimated as chord over turn,
/// 9.466 s; for the look-ahead speed 9.377 s; with LinuxCNC's blend geometry 9.325 s
/// (the input's own lines under `G64 P0.01`: 9.394 s). With evened blocks and the run's
/// ends 9.219 s; with half the acceleration on what the blends take 9.175 s
/// (camotics_vcarve arc 20.369 -> 20.347 s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlendSchedule {
    /// The run's `P` (mm), the largest written.
    pub p_mm: f64,
    /// The run's `Q` (mm), written unchanged.
    pub q_mm: f64,
    /// The machine's acceleration (mm/s^2).
    pub acc_mm_s2: f64,
    /// The machine's fastest feed (mm/s), which a feed override may reach: the blends
    /// are sized for it; infinite for the programmed feeds.
    pub feed_max_mm_s: f64,
}

impl BlendSchedule {
    /// The share of `P` for each block from `start` through `pts` (one per point), or an
    /// empty list when `feed_mm_s` is unknown. `ends` bound the speed estimate at the
    /// run's ends: after a rapid that turns into the run, LinuxCNC starts it nearly at
    /// rest, and its first blocks need only the blends their speed from there needs.
    pub fn shares(
        &self,
        start: Vec3,
        pts: &[Vec3],
        feed_mm_s: Option<f64>,
        ends: RunEnds,
    ) -> Vec<f64> {
        self.plan(start, pts, feed_mm_s, ends)
            .map_or_else(Vec::new, |p| p.block)
    }

    /// The speed estimate and shares of [`BlendSchedule::shares`], `None` when the feed
    /// is unknown.
    fn plan(
        &self,
        start: Vec3,
        pts: &[Vec3],
        feed_mm_s: Option<f64>,
        ends: RunEnds,
    ) -> Option<BlendPlan> {
        self.plan_in(start, pts, feed_mm_s, ends, BLEND_SCHEDULE_SPEED_PASSES)
    }

    /// [`BlendSchedule::plan`] with at most `passes` of the speed estimate.
    fn plan_in(
        &self,
        start: Vec3,
        pts: &[Vec3],
        feed_mm_s: Option<f64>,
        ends: RunEnds,
        passes: usize,
    ) -> Option<BlendPlan> {
        let fastest = Some(self.feed_max_mm_s).filter(|v| v.is_finite());
        let v = fastest.or(feed_mm_s).filter(|v| *v > 0.0)?;
        let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
        let n = pts.len();
        // blocks[k]: block k as a vector; blends[k]: the blend at the vertex ending it.
        let blocks: Vec<Vec3> = (0..n).map(|k| at(k + 1) - at(k)).collect();
        let tangent_rad = self.tangent_turn_rad(v);
        let blends: Vec<VertexBlend> = blocks
            .windows(2)
            .map(|b| VertexBlend::new(b[0], b[1], tangent_rad))
            .collect();
        // LinuxCNC accelerates along its blend arcs with half the acceleration: the
        // speeds are estimated again with the acceleration the shares leave, until the
        // shares settle.
        let mut arc_share = vec![0.0; n];
        let mut share = Vec::new();
        let mut vertex = Vec::new();
        let mut speed = Vec::new();
        for _ in 0..passes {
            speed = self.speeds(&blocks, &blends, v, ends, &arc_share);
            vertex = self.shares_at(blocks.len(), &blends, &speed);
            let next = Self::block_shares(&vertex, ends);
            let settled = next == share;
            share = next;
            if settled {
                break;
            }
            arc_share = self.arc_shares(&blocks, &blends, &share, &speed);
        }
        Some(BlendPlan {
            block: share,
            vertex,
            speed,
            blends,
            v,
        })
    }

    /// Splits that give a vertex the `P` its speed needs where both of its blocks carry
    /// more for their other vertices (a blend uses the smaller `P` of its two blocks):
    /// the block with room is cut by a point on its line, which LinuxCNC joins as tangent,
    /// and the piece at the vertex gets the vertex's share. `block` are the shares
    /// written (the plan's, raised at programmed corners), `rounded` puts a point on the
    /// written grid. Returns, per block, the point and the shares of its two pieces.
    ///
    /// A piece next to a blend holds twice what the blend takes (LinuxCNC takes at most
    /// half of a line) and four times its `P` (the blend tolerance is at most a quarter
    /// of the line), and the piece before a blend leaves [`LINUXCNC_BLEND_GAP_CYCLES`]
    /// of line at the vertex's speed, all with [`SPLIT_ROOM`]; the point is the one of
    /// [`SPLIT_CANDIDATES`] on the grid whose kink LinuxCNC's tangent rule takes with at
    /// most [`SPLIT_KINK_RATIO`] of the acceleration (tp.c `tpSetupTangent` lowers both
    /// pieces' acceleration by that share).
    fn splits(
        &self,
        plan: &BlendPlan,
        start: Vec3,
        pts: &[Vec3],
        block: &[f64],
        rounded: impl Fn(Vec3) -> Vec3,
    ) -> Vec<Option<Split>> {
        let n = pts.len();
        let mut out: Vec<Option<Split>> = vec![None; n];
        if block.len() != n {
            return out;
        }
        let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
        let kink_max =
            SPLIT_KINK_RATIO * self.acc_mm_s2 * crate::dialect::LINUXCNC_SERVO_PERIOD_S / plan.v;
        // Vertex k joins block k and block k + 1.
        for k in 0..n.saturating_sub(1) {
            // A vertex needing all of the run's `P` (or more) is left as it is: a share
            // above 1 is a programmed corner's own `P`.
            let want = Self::round_share(plan.vertex[k]);
            if want >= 1.0 || block[k].min(block[k + 1]) < want * SPLIT_MIN_GAIN {
                continue;
            }
            // Block k + 1 cut at its front (its end vertex keeps its share), or block k
            // at its back.
            let front = (k + 2 < n && out[k + 1].is_none()).then(|| {
                let keep = block[k + 1].min(block[k + 2]);
                let room = (
                    self.split_room(plan, k, want, false),
                    self.split_room(plan, k + 1, keep, true),
                );
                (k + 1, room, (want, block[k + 1]))
            });
            let back = (k >= 1 && out[k].is_none()).then(|| {
                let keep = block[k - 1].min(block[k]);
                let room = (
                    self.split_room(plan, k - 1, keep, false),
                    self.split_room(plan, k, want, true),
                );
                (k, room, (block[k], want))
            });
            let found = [front, back]
                .into_iter()
                .flatten()
                .find_map(|(j, room, shares)| {
                    let point = split_point(at(j), pts[j], room, &rounded, kink_max)?;
                    Some((j, Split { point, shares }))
                });
            if let Some((j, split)) = found {
                out[j] = Some(split);
            }
        }
        out
    }

    /// Length a piece needs next to vertex `k` under `share` of `P`; `before`: the piece
    /// ends there (LinuxCNC's line before the blend).
    fn split_room(&self, plan: &BlendPlan, k: usize, share: f64, before: bool) -> f64 {
        let p = share * self.p_mm;
        let reach = plan.blends[k].reach_mm(p);
        let gap = if before {
            reach + LINUXCNC_BLEND_GAP_S * plan.speed[k]
        } else {
            0.0
        };
        (2.0 * reach).max(gap).max(4.0 * p) * SPLIT_ROOM
    }

    /// `x` rounded up to a power of `2^(1/4)` ([`BLEND_SCHEDULE_STEPS_PER_HALVING`]), at
    /// most 1.
    fn round_share(x: f64) -> f64 {
        let steps = (x.log2() * BLEND_SCHEDULE_STEPS_PER_HALVING).ceil();
        2f64.powf(steps / BLEND_SCHEDULE_STEPS_PER_HALVING).min(1.0)
    }

    /// Each block's share from the shares at its two vertices: the larger (a blend uses
    /// the smaller `P` of its two blocks), rounded up to a power of `2^(1/4)`. The run's
    /// ends take all of `P` (a move outside the run may blend there), unless the machine
    /// is at rest there (LinuxCNC stops between a rapid and a feed move): then the end
    /// block's share is its other vertex's, and LinuxCNC's blend there takes no more of
    /// the block than that vertex's speed needs (camotics_vcarve trig: the first block
    /// after a plunge was blended with all of `P`, along its whole length, at half the
    /// acceleration).
    fn block_shares(vertex: &[f64], ends: RunEnds) -> Vec<f64> {
        let n = vertex.len();
        let end_share = |end: RunEnd| if end.at_rest() { 0.0 } else { 1.0 };
        (0..n)
            .map(|k| {
                let before = if k == 0 {
                    end_share(ends.before)
                } else {
                    vertex[k - 1]
                };
                let after = if k + 1 == n {
                    end_share(ends.after)
                } else {
                    vertex[k]
                };
                Self::round_share(before.max(after).max(BLEND_SCHEDULE_MIN_SHARE))
            })
            .collect()
    }

    /// The share of each block's length LinuxCNC's blends take under the blocks' shares
    /// `block` of `P` (a blend uses the smaller of its two blocks'): all of a block they
    /// consume.
    fn arc_shares(
        &self,
        blocks: &[Vec3],
        blends: &[VertexBlend],
        block: &[f64],
        speed: &[f64],
    ) -> Vec<f64> {
        let vertex: Vec<f64> = block.windows(2).map(|w| w[0].min(w[1])).collect();
        let last = speed.last().copied().unwrap_or(0.0);
        let at = |k: usize| speed.get(k).copied().unwrap_or(last);
        self.blend_takes(blocks, blends, &vertex, at)
            .into_iter()
            .zip(blocks)
            .map(|((taken, consumed), b)| if consumed { 1.0 } else { taken / b.norm() })
            .collect()
    }

    /// What LinuxCNC's blends take of each block (mm), the share of `P` at the vertex
    /// ending block k being `vertex[k]`, and whether they consume it: a block whose blends
    /// leave less than LinuxCNC's gap of straight line at `speed(k)` is consumed whatever
    /// its `P` (blendmath.c `blendCheckConsume`, at the blend's speed). At the run's ends,
    /// whose other side is not known here, the blend takes as much as LinuxCNC ever does.
    fn blend_takes(
        &self,
        blocks: &[Vec3],
        blends: &[VertexBlend],
        vertex: &[f64],
        speed: impl Fn(usize) -> f64,
    ) -> Vec<(f64, bool)> {
        // What the blend at the vertex ending block k takes of each line.
        let taken = |k: usize| match blends.get(k) {
            Some(b) => b.reach_mm(vertex[k] * self.p_mm),
            None => 0.5 * blocks[k].norm(),
        };
        (0..blocks.len())
            .map(|k| {
                let len = blocks[k].norm();
                let before = if k == 0 { 0.5 * len } else { taken(k - 1) };
                let arcs = before + taken(k);
                (arcs, len - arcs < LINUXCNC_BLEND_GAP_S * speed(k))
            })
            .collect()
    }

    /// The share of `P` at the vertex ending each of the `n` blocks for the speeds
    /// `speed` at the blends (1 at the run's end, which [`BlendSchedule::block_shares`]
    /// replaces by what the run's end needs).
    fn shares_at(&self, n: usize, blends: &[VertexBlend], speed: &[f64]) -> Vec<f64> {
        let a_n = LINUXCNC_NORMAL_ACC_SHARE * self.acc_mm_s2;
        (0..n)
            .map(|k| match blends.get(k) {
                Some(b) => {
                    let p = b.p_for_radius_mm(speed[k] * speed[k] / a_n);
                    (p / self.p_mm).clamp(BLEND_SCHEDULE_MIN_SHARE, 1.0)
                }
                None => 1.0,
            })
            .map(|x| if x.is_nan() { 1.0 } else { x })
            .collect()
    }

    /// The speed bound at a run's end whose block there is `block`: none where the end is
    /// free, 0 at rest, and where a move joins it, what LinuxCNC's blend within the run's
    /// `P` allows at that junction (the half-line bound, which needs the other move's
    /// length, left out: the bound errs high).
    fn end_speed(&self, end: RunEnd, block: Vec3) -> Option<f64> {
        match end {
            RunEnd::Free => None,
            RunEnd::Rest | RunEnd::Rapid => Some(0.0),
            RunEnd::Joins(d) => {
                let blend = VertexBlend {
                    half_line_mm: f64::INFINITY,
                    ..VertexBlend::new(d, block, 0.0)
                };
                let r = blend.radius_mm(self.p_mm);
                r.is_finite()
                    .then(|| (LINUXCNC_NORMAL_ACC_SHARE * self.acc_mm_s2 * r).sqrt())
            }
        }
    }

    /// The turn (rad) below which LinuxCNC joins two lines at feed `v` as tangent, without a
    /// blend (tp.c `tpSetupTangent`: the kink's acceleration `(v / T + a) turn` within
    /// [`LINUXCNC_TANGENT_KINK_RATIO`] of the axes' `a`).
    fn tangent_turn_rad(&self, v: f64) -> f64 {
        let a = self.acc_mm_s2;
        LINUXCNC_TANGENT_KINK_RATIO * a / (v / crate::dialect::LINUXCNC_SERVO_PERIOD_S + a)
    }

    /// Speed at each vertex (mm/s) between `blocks` (as vectors), `blends` at those
    /// vertices: at most `v`, what a blend with all of `P` allows, and what the
    /// acceleration along the blocks reaches from the neighbouring vertices: LinuxCNC's
    /// tangential limit of a line (the smallest axis limit over that axis's share of the
    /// direction) on the part of block `k` its blends leave, and
    /// [`LINUXCNC_TANGENTIAL_ACC_SHARE`] of the acceleration on the share `arc_share[k]`
    /// they take. The run's ends are bounded by `ends`.
    fn speeds(
        &self,
        blocks: &[Vec3],
        blends: &[VertexBlend],
        v: f64,
        ends: RunEnds,
        arc_share: &[f64],
    ) -> Vec<f64> {
        let a_n = LINUXCNC_NORMAL_ACC_SHARE * self.acc_mm_s2;
        let mut s: Vec<f64> = blends
            .iter()
            .map(|b| {
                let r = b.radius_mm(self.p_mm);
                if r.is_nan() {
                    v
                } else {
                    v.min((a_n * r).sqrt())
                }
            })
            .collect();
        // Speed reached from `from` along block `k`, whose blends take `arc_share[k]` of it.
        let along = |k: usize, from: f64| -> f64 {
            let d = blocks[k];
            let len = d.norm();
            let line = self.acc_mm_s2 * len / d.max_abs().max(f64::MIN_POSITIVE);
            let arc = LINUXCNC_TANGENTIAL_ACC_SHARE * self.acc_mm_s2;
            let x = arc_share.get(k).copied().unwrap_or(0.0);
            let acc = x * arc + (1.0 - x) * line;
            (from * from + 2.0 * acc * len).sqrt()
        };
        // Block k + 1 joins vertex k to vertex k + 1.
        let reach = |k: usize, from: f64| -> f64 { along(k + 1, from) };
        let n = blocks.len();
        if s.is_empty() {
            return s;
        }
        if let (Some(v0), Some(first)) = (self.end_speed(ends.before, blocks[0]), s.first_mut()) {
            *first = first.min(along(0, v0));
        }
        if let (Some(v1), Some(last)) = (self.end_speed(ends.after, blocks[n - 1]), s.last_mut()) {
            *last = last.min(along(n - 1, v1));
        }
        for k in 1..s.len() {
            s[k] = s[k].min(reach(k - 1, s[k - 1]));
        }
        for k in (0..s.len().saturating_sub(1)).rev() {
            s[k] = s[k].min(reach(k, s[k + 1]));
        }
        s
    }
}

/// Points sampled along each line where LinuxCNC's blend at a point given more than the
/// run's `P` may run, to bound the line's deviation there.
pub const ROOM_SAMPLES: usize = 32;

/// The `P` point `k` of a chain from `start` through `pts` (not the last) may take under
/// LinuxCNC, as a [`VertexRoom`]; `corner`: a programmed corner put in place of short
/// blocks. LinuxCNC's blend there runs within `reach` of the point along its two lines
/// (at most half of each, and what `c.max_p_mm` gives: [`VertexBlend`]) and within its
/// `P` of them.
///
/// * (a) Every point of the blend is within `P` of a point of the lines within reach,
///   which are at most `line_dev` from the programmed path ([`ROOM_SAMPLES`] samples
///   each, 1-Lipschitz).
/// * (b) A programmed vertex whose nearest written point is within reach is at most its
///   distance to it plus the blend's depth from the executed path (`gap`: the largest
///   such distance, given the parts within reach and the written lines around them).
///
/// The blend may take what the tolerance leaves after the larger of the two, up to
/// `c.max_p_mm`.
fn vertex_room(
    k: usize,
    start: Vec3,
    pts: &[Vec3],
    corner: bool,
    c: crate::rewrite::CornerBlend,
    line_dev: impl Fn(Vec3, Vec3) -> f64,
    gap: impl Fn(&[(Vec3, Vec3)], &[(Vec3, Vec3)]) -> f64,
) -> VertexRoom {
    let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
    let (a, v, b) = (at(k), pts[k], pts[k + 1]);
    let reach = VertexBlend::new(v - a, b - v, 0.0).reach_mm(c.max_p_mm);
    let toward = |p: Vec3| v + (p - v) * (reach / v.dist(p)).min(0.5);
    let (ra, rb) = (toward(a), toward(b));
    let within = [(ra, v), (v, rb)];
    // The rest of the written lines around them.
    let mut others = vec![(a, ra), (rb, b)];
    others.extend((k >= 1).then(|| (at(k - 1), a)));
    others.extend((k + 2 < pts.len()).then(|| (b, pts[k + 2])));
    let taken = line_dev(ra, v)
        .max(line_dev(v, rb))
        .max(gap(&within, &others));
    let p_mm = c.max_p_mm.min(c.total_mm - taken);
    VertexRoom {
        p_mm: if p_mm.is_nan() { 0.0 } else { p_mm },
        corner,
    }
}

/// The `P` a written point may take under LinuxCNC ([`vertex_room`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct VertexRoom {
    /// Largest `P` (mm) within the tolerance there.
    p_mm: f64,
    /// A programmed corner put in place of short blocks.
    corner: bool,
}

/// Raises the blocks' shares `block` of the run's `P` (`run_p_mm`) so that the blends at
/// the programmed corners put in place of short blocks, and at the points `sharp` says
/// need all of the run's `P` (giving their speed estimate), get what `rooms` allows them.
/// LinuxCNC blends a point with the smaller `P` of its two blocks, so a point's raise
/// lifts both of them, as far as the points at their other ends stay within their own
/// room (or the share they had: the run's `P` is within the tolerance only where the
/// model of the executed path confirms it). Corners go first, then the slowest points;
/// a chain's end point is raised only next to a stop (`ends` at rest: LinuxCNC stops
/// between a rapid and a feed move, tp.c `tpCheckCanonType`), since the move beyond it
/// has a `P` of its own.
fn raise_for_rooms(
    block: &mut [f64],
    rooms: &[Option<VertexRoom>],
    run_p_mm: f64,
    ends: RunEnds,
    sharp: impl Fn(usize) -> Option<f64>,
) {
    let n = block.len();
    // The largest share each point's blend may get: its room, or what it had.
    let had: Vec<f64> = block.windows(2).map(|w| w[0].min(w[1])).collect();
    let lim = |k: usize| match rooms.get(k).copied().flatten() {
        Some(r) => (r.p_mm / run_p_mm).max(had[k]),
        None => had[k],
    };
    let (first, last) = raised_span(n, ends);
    // Corners first, then the slowest points.
    let mut order: Vec<(usize, f64, f64)> = rooms
        .iter()
        .enumerate()
        .filter_map(|(k, r)| Some((k, (*r)?)))
        .filter(|&(k, r)| r.p_mm > run_p_mm && k + 1 < n)
        .filter_map(|(k, r)| match (r.corner, k >= first && k + 1 < last) {
            (true, _) => Some((k, f64::NEG_INFINITY, r.p_mm)),
            (false, true) => sharp(k).map(|v| (k, v, r.p_mm)),
            (false, false) => None,
        })
        .collect();
    order.sort_by(|x, y| x.1.total_cmp(&y.1));
    for (k, _, p_mm) in order {
        let share = p_mm / run_p_mm;
        // Each block's raise, held where the point at its other end would get more than
        // it may.
        let mut a = block[k].max(share);
        if k >= 1 && block[k - 1] > lim(k - 1) {
            a = a.min(lim(k - 1).max(block[k]));
        }
        let mut b = block[k + 1].max(share);
        if k + 2 < n && block[k + 2] > lim(k + 1) {
            b = b.min(lim(k + 1).max(block[k + 1]));
        }
        let got = a.min(b);
        if got > 1.0 {
            block[k] = block[k].max(got);
            block[k + 1] = block[k + 1].max(got);
        }
    }
}

/// The points of a chain of `n` blocks (`first..last - 1`) whose blend may be raised
/// unless they are programmed corners: not a chain's end point next to a move of
/// unknown `P` (`ends`), which LinuxCNC blends with the smaller of the two.
fn raised_span(n: usize, ends: RunEnds) -> (usize, usize) {
    let first = if ends.before.at_rest() { 0 } else { 1 };
    let last = if ends.after.at_rest() {
        n
    } else {
        n.saturating_sub(1)
    };
    (first, last)
}

/// LinuxCNC's blend arc between two lines (blendmath.c `blendComputeParameters`): tangent
/// to both, it takes at most half of each line (`BLEND_DIST_FRACTION`) and, within `P`,
/// at most `P / tan(phi / 4)` of each, `phi` the turn; its radius is what it takes over
/// `tan(phi / 2)`.
#[derive(Clone, Copy, Debug)]
struct VertexBlend {
    /// `tan(phi / 2)`.
    tan_half: f64,
    /// `tan(phi / 4)`.
    tan_quarter: f64,
    /// Half the shorter line (mm).
    half_line_mm: f64,
}

impl VertexBlend {
    /// The blend between lines `u` and `w`; none (it takes nothing, and its radius is
    /// NaN) where they turn less than `tangent_rad`.
    fn new(u: Vec3, w: Vec3, tangent_rad: f64) -> VertexBlend {
        let phi = u.angle_to(w);
        if phi < tangent_rad {
            return VertexBlend {
                tan_half: 0.0,
                tan_quarter: 0.0,
                half_line_mm: 0.0,
            };
        }
        VertexBlend {
            tan_half: (0.5 * phi).tan(),
            tan_quarter: (0.25 * phi).tan(),
            half_line_mm: 0.5 * u.norm().min(w.norm()),
        }
    }

    /// Length of each line a blend within `p_mm` takes.
    fn reach_mm(&self, p_mm: f64) -> f64 {
        self.half_line_mm.min(p_mm / self.tan_quarter)
    }

    /// How far inside the vertex the blend within `p_mm` passes (at most `p_mm`).
    fn depth_mm(&self, p_mm: f64) -> f64 {
        self.reach_mm(p_mm) * self.tan_quarter
    }

    /// Radius of the blend within `p_mm`.
    fn radius_mm(&self, p_mm: f64) -> f64 {
        self.reach_mm(p_mm) / self.tan_half
    }

    /// The least `P` whose blend has radius `r_mm`, or all the lines allow.
    fn p_for_radius_mm(&self, r_mm: f64) -> f64 {
        (r_mm * self.tan_half).min(self.half_line_mm) * self.tan_quarter
    }
}

/// Writes moves as G0/G1/G2/G3 lines: axis words only when their printed value changes,
/// arcs on the planes G-code has, everything else flattened.
pub(crate) struct MotionWriter {
    pub frame: Frame,
    pub line_numbers: bool,
    n: u64,
    pub line: String,
    scratch: String,
    last_axis: [String; 3],
    axis_known: [bool; 3],
    /// The last position written (unrounded; see `written_pos`).
    written: Vec3,
    last_extra: [String; 7],
    extra_known: [bool; 7],
    /// Extra-axis values written last (for interpolation and relative E: there, what the
    /// written increments add up to).
    last_extra_val: [f64; 7],
    /// Relative E: the program's value at the last written increment.
    last_e_target: f64,
    last_f: String,
    f_known: bool,
    /// The last motion code written (0, 1, 2, 3), if any.
    pub last_motion: Option<u8>,
    points: Vec<Vec3>,
    /// An axis that may not be written would have had to change: (axis, value mm).
    pub violation: Option<(char, f64)>,
    /// Under a long-lines emitter, short blocks are lifted against this program.
    pub floor: Option<Floor>,
    /// LinuxCNC's `G64 P` of the runs (mm): the long-lines emitter evens out its blocks
    /// for the blends ([`crate::chain::even_out`]).
    pub blend_p_mm: Option<f64>,
    /// Per-block `G64 P` under a long-lines emitter (LinuxCNC).
    pub blend_schedule: Option<BlendSchedule>,
    /// Share of the schedule's `P` in force.
    blend_share: f64,
    /// A `G64` line (without its end of line) to write before the next line: a bound set
    /// while no move follows it yet. One set before the first is written replaces it (a
    /// chain's first block with a share of its own after the run's `P`), so no `G64` is
    /// written that no move runs under.
    pub blend_pending: Option<String>,
    /// What moves next to the moves [`MotionWriter::write_moves`] is given.
    pub run_ends: RunEnds,
    /// What moves next to the chain being written.
    chain_ends: RunEnds,
    /// The extra axes along the chain being written, when its moves carry them.
    chain_extra: Option<ExtraProfile>,
    /// The programmed point a verbatim line continues from after these moves (mm): a
    /// block ending there (within [`EXACT_END_SNAP_MM`]) writes it with the digits that
    /// read back as exactly that point ([`MotionWriter::fmt_exact`]), so that a rapid, a
    /// full circle or an incremental move after it starts where the program has it.
    pub exact_end: Option<Vec3>,
    /// [`MotionWriter::exact_end`] while the block that ends there is written.
    exact_now: Option<Vec3>,
}

/// Distance (mm) within which a written block ends on the programmed point a run ends at
/// (the writer then prints that point with its own digits).
pub const EXACT_END_SNAP_MM: f64 = 1e-9;

const AXIS_LETTERS: [char; 3] = ['X', 'Y', 'Z'];

/// Under the long-lines emitter, an arc whose flattening within the chord takes at least
/// this many lines is written as `G2`/`G3` (where its plane allows and the dialect keeps
/// long arcs, [`crate::Dialect::keeps_long_arcs`]) and ends the chain of lines; shorter
/// arcs (the small transitions of a smoothed corner) join the chain.
pub const NATIVE_ARC_MIN_BLOCKS: f64 = 4.0;

/// Largest spread of Z (mm) among the control points of a curve written as `G5`/`G5.2`
/// (which carry no Z): numerical noise of a fit in a plane, below any printed decimal.
const PLANAR_Z_MM: f64 = 1e-9;

/// Digits after the point of `G5.2` weights.
const NURBS_WEIGHT_DECIMALS: usize = 12;

/// [`MotionWriter::last_motion`] after a `G5` (no G0-G3 mode is in force).
pub(crate) const G5_MOTION: u8 = 5;

/// Flattening chord (mm) used when a frame's chord is not positive.
const DEFAULT_CHORD_MM: f64 = 0.001;

/// Smallest chord (mm) of an arc of less than half a turn written as G2/G3; shorter arcs
/// are flattened (into one or a few G1 lines within the chord tolerance: their sagitta is
/// tiny). A reader that rounds the end points (LinuxCNC's canonical output prints four
/// decimals, grbl computes in single precision) could otherwise take such an arc for a full
/// circle.
pub const MIN_ARC_CHORD_MM: f64 = 0.005;
/// The same minimum in units of the last written decimal.
const MIN_ARC_CHORD_UNITS: f64 = 20.0;

/// Smallest arc radius written as G2/G3 (mm): twice LinuxCNC's zero-radius limit
/// ([`crate::interp::motion::RADIUS_TOLERANCE_MM`]), so that no reader refuses it; smaller
/// arcs are flattened.
pub const MIN_ARC_RADIUS_MM: f64 = 2.0 * crate::interp::motion::RADIUS_TOLERANCE_MM;

/// Extra digits for the I/J/K centre offsets: the reader's centre is then essentially
/// exact relative to the rounded end points, so the arc between them deviates from the
/// original by about the end-point rounding only (with the same digits as the
/// coordinates, the centre rounding adds up to the same amount again, and arc midpoints
/// of a 6-decimal round trip could move by up to 1.4e-6 mm).
pub const CENTRE_EXTRA_DECIMALS: usize = 2;

fn coord(v: Vec3, i: usize) -> f64 {
    match i {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

fn set_coord(v: &mut Vec3, i: usize, x: f64) {
    match i {
        0 => v.x = x,
        1 => v.y = x,
        _ => v.z = x,
    }
}

impl MotionWriter {
    /// A writer at `start` (mm): the allowed axes are taken as already written there.
    pub(crate) fn new(frame: Frame, start: Vec3) -> MotionWriter {
        let mut w = MotionWriter {
            frame,
            line_numbers: false,
            n: 0,
            line: String::with_capacity(128),
            scratch: String::with_capacity(32),
            last_axis: Default::default(),
            axis_known: [false; 3],
            written: start,
            last_extra: Default::default(),
            extra_known: [false; 7],
            last_extra_val: [0.0; 7],
            last_e_target: 0.0,
            last_f: String::new(),
            f_known: false,
            last_motion: None,
            points: Vec::new(),
            violation: None,
            floor: None,
            blend_p_mm: None,
            blend_schedule: None,
            blend_share: 1.0,
            blend_pending: None,
            run_ends: RunEnds::default(),
            chain_ends: RunEnds::default(),
            chain_extra: None,
            exact_end: None,
            exact_now: None,
        };
        w.forget_axes();
        w
    }

    /// Coordinate decimals, clamped to [`MAX_DECIMALS`].
    fn decimals(&self) -> usize {
        self.frame.decimals.min(MAX_DECIMALS)
    }

    pub(crate) fn begin(&mut self) {
        self.line.clear();
        if self.line_numbers {
            self.n += 1;
            let _ = write!(self.line, "N{} ", self.n);
        }
    }

    pub(crate) fn end<W: fmt::Write>(&mut self, out: &mut W) -> fmt::Result {
        if let Some(g64) = self.blend_pending.take() {
            out.write_str(&g64)?;
            out.write_char('\n')?;
        }
        out.write_str(&self.line)?;
        out.write_char('\n')
    }

    /// The next move writes every axis (the position was changed by something else).
    pub(crate) fn forget_axes(&mut self) {
        self.axis_known = [false; 3];
    }

    /// The next move writes its extra axes again.
    pub(crate) fn forget_extras(&mut self) {
        self.extra_known = [false; 7];
    }

    /// The next feed move writes F again.
    pub(crate) fn forget_feed(&mut self) {
        self.f_known = false;
    }

    /// Relative E (M83): what the written increments add up to less the program's value,
    /// within half a written unit. A later run's increments start from it
    /// ([`MotionWriter::assume_at`]), so the rounding never accumulates across runs.
    pub(crate) fn relative_e_carry(&self) -> f64 {
        self.last_extra_val[6] - self.last_e_target
    }

    /// The program's extra-axis values at the last written point (with relative E, what
    /// the written increments add up to is [`MotionWriter::relative_e_carry`] away).
    fn program_extra(&self) -> [f64; 7] {
        let mut e = self.last_extra_val;
        if self.frame.e_relative {
            e[6] = self.last_e_target;
        }
        e
    }

    /// Sets the position the reader is at (mm), as if written: axes whose printed value
    /// does not change are not written again. With relative E, `e_carry` is what the
    /// machine's E is ahead of `extra` ([`MotionWriter::relative_e_carry`] of the run
    /// before, when no reset came between).
    pub(crate) fn assume_at(&mut self, p: Vec3, extra: Option<&[f64; 7]>, e_carry: f64) {
        for i in 0..3 {
            let v = self.mm_to_units(i, coord(p, i));
            self.fmt(v);
            std::mem::swap(&mut self.last_axis[i], &mut self.scratch);
            self.axis_known[i] = true;
        }
        self.written = p;
        if let Some(e) = extra {
            self.last_extra_val = *e;
            self.last_e_target = e[6];
            if self.frame.e_relative {
                self.last_extra_val[6] += e_carry;
            }
            for i in 0..7 {
                let v = self.extra_units(i, e[i]);
                self.fmt_extra(i, v);
                std::mem::swap(&mut self.last_extra[i], &mut self.scratch);
                self.extra_known[i] = true;
            }
        }
    }

    /// Axis value `v` (mm) in written units.
    fn mm_to_units(&self, i: usize, v: f64) -> f64 {
        let v = v / self.frame.scale;
        if i == 0 && self.frame.diameter {
            2.0 * v
        } else {
            v
        }
    }

    /// Written units back to mm.
    fn units_to_mm(&self, i: usize, v: f64) -> f64 {
        let v = if i == 0 && self.frame.diameter {
            v / 2.0
        } else {
            v
        };
        v * self.frame.scale
    }

    /// Extra axis `i` (A B C U V W E) in written units.
    fn extra_units(&self, i: usize, v: f64) -> f64 {
        if i < 3 {
            v
        } else {
            v / self.frame.scale
        }
    }

    /// Formats `v` into the scratch buffer.
    fn fmt(&mut self, v: f64) {
        self.fmt_to(v, self.decimals());
    }

    /// Formats `v` into the scratch buffer with `decimals` digits (at most [`MAX_DECIMALS`]).
    fn fmt_to(&mut self, v: f64, decimals: usize) {
        self.scratch.clear();
        push_fixed(&mut self.scratch, v, decimals.min(MAX_DECIMALS));
    }

    /// Formats axis `i`'s value `v` (mm) with the fewest decimals, from the frame's on,
    /// that read back as exactly `v` (a point of the program: its own digits), or with
    /// [`MAX_DECIMALS`] when none does.
    fn fmt_exact(&mut self, i: usize, v: f64) {
        let u = self.mm_to_units(i, v);
        for d in self.decimals()..=MAX_DECIMALS {
            self.fmt_to(u, d);
            if self
                .scratch
                .parse::<f64>()
                .is_ok_and(|b| self.units_to_mm(i, b) == v)
            {
                return;
            }
        }
    }

    /// [`MotionWriter::exact_end`] when a block to `p` ends there (`p` the point itself or
    /// its rounding to the written decimals, as the long-lines emitter chooses its ends).
    fn exact_at(&self, p: Vec3) -> Option<Vec3> {
        self.exact_end.filter(|&e| {
            e.dist(p) <= EXACT_END_SNAP_MM || self.rounded(e).dist(p) <= EXACT_END_SNAP_MM
        })
    }

    /// One unit of the last written digit, in mm.
    fn unit_mm(&self) -> f64 {
        0.1f64.powi(self.decimals() as i32) * self.frame.scale
    }

    /// Formats extra axis `i`'s value `v` (written units): `E` with
    /// [`E_EXTRA_DECIMALS`] more digits than the coordinates.
    fn fmt_extra(&mut self, i: usize, v: f64) {
        let more = if i == 6 { E_EXTRA_DECIMALS } else { 0 };
        self.fmt_to(v, self.decimals() + more);
    }

    fn allowed(&self, i: usize) -> bool {
        self.frame.allowed_xyz & (1 << i) != 0
    }

    /// Appends axis `i` = `v` (mm) when forced or changed; updates the written position.
    /// An axis that may not be written is never written: if its value would change, the
    /// violation is recorded.
    fn axis(&mut self, i: usize, v: f64, force: bool) -> bool {
        let v = match self.exact_now.filter(|_| self.allowed(i)) {
            Some(e) => {
                self.fmt_exact(i, coord(e, i));
                coord(e, i)
            }
            None => {
                let u = self.mm_to_units(i, v);
                self.fmt(u);
                v
            }
        };
        if !self.allowed(i) {
            if self.axis_known[i] && self.scratch != self.last_axis[i] && self.violation.is_none() {
                self.violation = Some((AXIS_LETTERS[i], v));
            }
            return false;
        }
        if force || !self.axis_known[i] || self.scratch != self.last_axis[i] {
            self.line.push(' ');
            self.line.push(AXIS_LETTERS[i]);
            self.line.push_str(&self.scratch);
            std::mem::swap(&mut self.last_axis[i], &mut self.scratch);
            self.axis_known[i] = true;
            set_coord(&mut self.written, i, v);
            true
        } else {
            false
        }
    }

    /// The position the reader computes: the written (rounded) coordinates (mm).
    fn written_pos(&self) -> Vec3 {
        let mut p = self.written;
        for i in 0..3 {
            if self.axis_known[i] {
                if let Ok(v) = self.last_axis[i].parse() {
                    set_coord(&mut p, i, self.units_to_mm(i, v));
                }
            }
        }
        p
    }

    fn extras(&mut self, e: Option<&[f64; 7]>) {
        let Some(e) = e else { return };
        for i in 0..7 {
            if self.frame.extra_mask & (1 << i) == 0 {
                continue;
            }
            let relative_e = i == 6 && self.frame.e_relative;
            if relative_e {
                // M83: the word is the increment from what was written last.
                let d = self.extra_units(i, e[i] - self.last_extra_val[i]);
                self.fmt_extra(i, d);
                if self.scratch != "0" {
                    self.line.push_str(" E");
                    self.line.push_str(&self.scratch);
                    // Track the rounded increment so that errors do not accumulate.
                    let written: f64 = self.scratch.parse().unwrap_or(0.0);
                    self.last_extra_val[i] += written * self.frame.scale;
                }
                self.last_e_target = e[i];
                continue;
            }
            let v = self.extra_units(i, e[i]);
            self.fmt_extra(i, v);
            if !self.extra_known[i] || self.scratch != self.last_extra[i] {
                self.line.push(' ');
                self.line.push(EXTRA_AXIS_NAMES[i]);
                self.line.push_str(&self.scratch);
                std::mem::swap(&mut self.last_extra[i], &mut self.scratch);
                self.extra_known[i] = true;
            }
            self.last_extra_val[i] = e[i];
        }
    }

    fn feed(&mut self, m: &Move) {
        if m.kind != MoveKind::Feed {
            return;
        }
        if let Some(f) = m.feed_mm_s {
            // A feed below the last written digit (`F0.00001`) gets the digits it needs:
            // written as `F0`, the program would not run.
            let per_min = f * 60.0 / self.frame.scale;
            let mut decimals = self.decimals();
            self.fmt_to(per_min, decimals);
            while self.scratch == "0" && per_min > 0.0 && decimals < MAX_DECIMALS {
                decimals += 1;
                self.fmt_to(per_min, decimals);
            }
            if !self.f_known || self.scratch != self.last_f {
                self.line.push_str(" F");
                self.line.push_str(&self.scratch);
                std::mem::swap(&mut self.last_f, &mut self.scratch);
                self.f_known = true;
            }
        }
    }

    /// The feed last written (units per minute), if any.
    pub(crate) fn last_feed(&self) -> Option<f64> {
        self.f_known.then(|| self.last_f.parse().ok()).flatten()
    }

    /// Writes a G0/G1 to `p`. A move whose every printed coordinate is unchanged is not
    /// written (the reader would run a zero-length block); its feed goes with the next.
    fn linear<W: fmt::Write>(
        &mut self,
        m: &Move,
        p: Vec3,
        extra: Option<&[f64; 7]>,
        out: &mut W,
    ) -> fmt::Result {
        self.begin();
        let code = if m.kind == MoveKind::Rapid { 0 } else { 1 };
        let _ = write!(self.line, "G{code}");
        let bare = self.line.len();
        self.exact_now = self.exact_at(p);
        for i in 0..3 {
            self.axis(i, coord(p, i), false);
        }
        self.exact_now = None;
        self.extras(extra);
        if self.line.len() == bare {
            return Ok(());
        }
        self.feed(m);
        self.last_motion = Some(code);
        self.end(out)
    }

    /// Appends ` <letter><v>` for a length `v` (mm) in written units with
    /// [`CENTRE_EXTRA_DECIMALS`] more digits than the coordinates: arc centres, G5 control
    /// offsets and interior G5.2 control points, which must not add their own rounding
    /// to that of the end points.
    fn push_fine(&mut self, letter: char, v: f64) {
        self.scratch.clear();
        let decimals = self.decimals() + CENTRE_EXTRA_DECIMALS;
        push_fixed(&mut self.scratch, v / self.frame.scale, decimals);
        self.line.push(' ');
        self.line.push(letter);
        self.line.push_str(&self.scratch);
    }

    /// Where `p` (mm) will be read back from: each writable axis rounded to the written
    /// decimals (the others are not written).
    fn rounded(&self, p: Vec3) -> Vec3 {
        let p10 = 10f64.powi(self.decimals() as i32);
        let mut q = p;
        for i in 0..3 {
            if self.allowed(i) {
                let u = (self.mm_to_units(i, coord(p, i)) * p10).round() / p10;
                set_coord(&mut q, i, self.units_to_mm(i, u));
            }
        }
        q
    }

    /// Whether `m` may join a chain of long G1 blocks, long arcs aside
    /// ([`MotionWriter::chainable_at`]): a feed move outside diameter mode, without extra
    /// axes or with `E` the only one written (a printer's extrusion, carried along the
    /// blocks by [`ExtraProfile`]; a rotary axis is not a length of the path), and no
    /// curve that `G5`/`G5.2` carries.
    fn chain_candidate(&self, m: &Move) -> bool {
        let native_curve =
            !self.moves_extra(m) && (self.g5_able(&m.segment) || self.nurbs_able(&m.segment));
        m.kind == MoveKind::Feed
            && (m.extra.is_none() || self.frame.extra_mask & !E_AXIS_BIT == 0)
            && !self.frame.diameter
            && !native_curve
    }

    /// Whether `moves[k]` may join a chain. A long arc stays native when the dialect keeps
    /// long arcs ([`ChainMode::long_arcs`]); otherwise only where both its neighbours meet
    /// it as programmed: a line (the program's own joint, tangent or a corner), another
    /// native move or the end of the run. Next to a flattened curve, whose first chord is
    /// off the arc's tangent by half its turn, it is flattened too.
    fn chainable_at(&self, moves: &[&Move], k: usize) -> bool {
        let m = moves[k];
        if !self.chain_candidate(m) {
            return false;
        }
        if !self.long_arc(&m.segment) {
            return true;
        }
        if self.frame.chain.is_none_or(|c| c.long_arcs) {
            return false;
        }
        let meets_as_programmed = |j: Option<usize>| {
            j.and_then(|j| moves.get(j)).is_none_or(|n| {
                matches!(n.segment, Segment::Line(_))
                    || !self.chain_candidate(n)
                    || self.long_arc(&n.segment)
            })
        };
        !(meets_as_programmed(k.checked_sub(1)) && meets_as_programmed(Some(k + 1)))
    }

    /// Whether `s` is a NURBS that `G5.2` carries: NURBS output is on, the curve lies in
    /// an XY plane (Z constant) and X and Y may be written.
    fn nurbs_able(&self, s: &Segment) -> bool {
        match s {
            Segment::Nurbs(n) => self.nurbs_curve_able(n),
            _ => false,
        }
    }

    /// See [`MotionWriter::nurbs_able`].
    fn nurbs_curve_able(&self, n: &Nurbs) -> bool {
        let z0 = n.ctrl()[0].z;
        self.frame.nurbs
            && !self.frame.diameter
            && self.allowed(0)
            && self.allowed(1)
            && n.ctrl().iter().all(|c| (c.z - z0).abs() <= PLANAR_Z_MM)
    }

    /// Writes a NURBS as one `G5.2 ... G5.3` per Bézier span (A5.6), each LinuxCNC's
    /// rational B-spline of order `degree + 1` on the clamped knots `0^k 1^k`, i.e. the
    /// span's rational Bézier with its weights scaled so that the first is 1 (LinuxCNC
    /// gives the current point weight 1): the same curve, moved by the rounding of its
    /// control points at most (positive weights: a convex combination of them). Interior
    /// control points get [`CENTRE_EXTRA_DECIMALS`] more digits. False when it must be
    /// flattened.
    fn try_nurbs<W: fmt::Write>(
        &mut self,
        m: &Move,
        n: &Nurbs,
        out: &mut W,
    ) -> Result<bool, fmt::Error> {
        if !self.nurbs_curve_able(n) || self.moves_extra(m) {
            return Ok(false);
        }
        let order = n.degree() + 1;
        for piece in n.bezier_pieces() {
            let w0 = piece[0][3];
            for (i, q) in piece.iter().enumerate().skip(1) {
                let (x, y, w) = (q[0] / q[3], q[1] / q[3], q[3] / w0);
                self.begin();
                if i == 1 {
                    if self.frame.plane != 17 {
                        self.line.push_str("G17 ");
                        self.frame.plane = 17;
                    }
                    self.line.push_str("G5.2");
                }
                if i + 1 == order {
                    self.axis(0, x, true);
                    self.axis(1, y, true);
                } else {
                    self.push_fine('X', x);
                    self.push_fine('Y', y);
                }
                self.line.push_str(" P");
                push_fixed(&mut self.line, w, NURBS_WEIGHT_DECIMALS);
                if i == 1 {
                    let _ = write!(self.line, " L{order}");
                    self.feed(m);
                }
                self.end(out)?;
            }
            self.begin();
            self.line.push_str("G5.3");
            self.end(out)?;
        }
        self.last_motion = Some(G5_MOTION);
        Ok(true)
    }

    /// Whether `m` carries extra axes the writer writes: `G5` and `G5.2` may not move
    /// them (LinuxCNC's rule), so such a curve is flattened, its lines carrying them.
    fn moves_extra(&self, m: &Move) -> bool {
        m.extra.is_some() && self.frame.extra_mask != 0
    }

    /// Whether `s` is a cubic Bézier that `G5` carries: G5 is on, the curve lies in an XY
    /// plane (Z constant) and X and Y may be written.
    fn g5_able(&self, s: &Segment) -> bool {
        match s {
            Segment::CubicBez(b) => self.g5_curve_able(b),
            _ => false,
        }
    }

    /// See [`MotionWriter::g5_able`].
    fn g5_curve_able(&self, b: &CubicBez) -> bool {
        self.frame.g5
            && !self.frame.diameter
            && self.allowed(0)
            && self.allowed(1)
            && [b.p1.z, b.p2.z, b.p3.z]
                .iter()
                .all(|&z| (z - b.p0.z).abs() <= PLANAR_Z_MM)
    }

    /// Writes a cubic Bézier as `G5 X Y I J P Q` (first control point relative to the
    /// written start, second relative to the written end, both with
    /// [`CENTRE_EXTRA_DECIMALS`] more digits, so the reader's curve is the original one
    /// moved by the end points' rounding at most); false when it must be flattened.
    fn try_g5<W: fmt::Write>(
        &mut self,
        m: &Move,
        b: &CubicBez,
        out: &mut W,
    ) -> Result<bool, fmt::Error> {
        if !self.g5_curve_able(b) || self.moves_extra(m) {
            return Ok(false);
        }
        let start = self.written_pos();
        self.begin();
        if self.frame.plane != 17 {
            self.line.push_str("G17 ");
            self.frame.plane = 17;
        }
        self.line.push_str("G5");
        self.axis(0, b.p3.x, true);
        self.axis(1, b.p3.y, true);
        let end = self.written_pos();
        self.push_fine('I', b.p1.x - start.x);
        self.push_fine('J', b.p1.y - start.y);
        self.push_fine('P', b.p2.x - end.x);
        self.push_fine('Q', b.p2.y - end.y);
        self.feed(m);
        // G5 is a motion mode of its own: a following modal line must get its code back.
        self.last_motion = Some(G5_MOTION);
        self.end(out)?;
        Ok(true)
    }

    /// An arc that one `G2`/`G3` carries better than the lines of a chain: flattened it
    /// would take at least [`NATIVE_ARC_MIN_BLOCKS`] chords.
    fn long_arc(&self, s: &Segment) -> bool {
        let Segment::Arc(a) = s else {
            return false;
        };
        let c = self.chord();
        if a.radius.is_nan() || a.radius <= c {
            return false;
        }
        let per_chord = 2.0 * (1.0 - c / a.radius).acos();
        a.sweep >= NATIVE_ARC_MIN_BLOCKS * per_chord
    }

    /// Writes consecutive moves: with [`Frame::chain_min_block_mm`], each run of
    /// chainable moves at one feed as long G1 blocks ([`crate::chain`]), the rest move by
    /// move.
    pub(crate) fn write_moves<W: fmt::Write>(
        &mut self,
        moves: &[&Move],
        out: &mut W,
    ) -> fmt::Result {
        let Some(mode) = self.frame.chain else {
            return moves.iter().try_for_each(|m| self.write_move(m, out));
        };
        let mut k = 0;
        while k < moves.len() {
            let m = moves[k];
            let mut e = k + 1;
            let chainable = self.chainable_at(moves, k);
            if chainable {
                while e < moves.len()
                    && self.chainable_at(moves, e)
                    && moves[e].feed_mm_s == m.feed_mm_s
                {
                    e += 1;
                }
            }
            // A lone line or arc is written as itself; a lone curve is flattened as a chain.
            let lone_curve = chainable && !matches!(m.segment, Segment::Line(_) | Segment::Arc(_));
            if e - k > 1 || lone_curve {
                let min_block = mode
                    .min_block_mm
                    .max(m.feed_mm_s.unwrap_or(0.0) * mode.min_block_s);
                self.chain_ends = RunEnds {
                    before: if k == 0 {
                        self.run_ends.before
                    } else {
                        RunEnd::Free
                    },
                    after: if e == moves.len() {
                        self.run_ends.after
                    } else {
                        RunEnd::Free
                    },
                };
                self.write_chain(&moves[k..e], min_block, mode.arcs, out)?;
            } else {
                self.write_move(m, out)?;
            }
            k = e;
        }
        Ok(())
    }

    /// Writes a run of chainable moves as long G1 blocks within the chord tolerance.
    fn write_chain<W: fmt::Write>(
        &mut self,
        moves: &[&Move],
        min_block_mm: f64,
        arcs: bool,
        out: &mut W,
    ) -> fmt::Result {
        let chord = self.chord();
        let dense_tol = chord * crate::chain::DENSE_SHARE;
        let mut dense = std::mem::take(&mut self.points);
        dense.clear();
        dense.push(moves[0].segment.start());
        let mut profile = moves
            .iter()
            .any(|m| self.moves_extra(m))
            .then(|| ExtraProfile::new(self.program_extra()));
        for m in moves {
            let mut push = |p: Vec3| {
                if dense.last() != Some(&p) {
                    dense.push(p);
                }
            };
            match &m.segment {
                Segment::Line(l) => push(l.p1),
                s => s.flatten(dense_tol, &mut push),
            }
            if let Some(profile) = profile.as_mut() {
                profile.push_move(&dense, m.extra.as_ref());
            }
        }
        // Lines are their own dense points: merging may use the whole chord.
        let all_lines = moves.iter().all(|m| matches!(m.segment, Segment::Line(_)));
        let tol = if all_lines { chord } else { chord - dense_tol };
        let mut hard = crate::chain::sharp_points(&dense, tol);
        if let Some(profile) = profile.as_mut() {
            profile.rate_breaks(&mut hard);
            profile.attach(&dense, &hard);
        }
        self.chain_extra = profile;
        let r = if arcs {
            self.write_arc_pieces(moves[0], &dense, &hard, tol, out)
        } else {
            let dense_acc = if all_lines { 0.0 } else { dense_tol };
            self.write_lines(
                moves[0],
                &dense,
                &hard,
                tol,
                dense_acc,
                min_block_mm,
                true,
                out,
            )
        };
        self.points = dense;
        self.chain_extra = None;
        r
    }

    /// The extra-axis values a written point `p` of the chain being written carries
    /// ([`ExtraProfile::at`]); `None` when its moves carry none.
    fn chain_values(&mut self, p: Vec3) -> Option<[f64; 7]> {
        let len_mm = self.written_pos().dist(p);
        let snap_mm = self.unit_mm();
        let profile = self.chain_extra.as_mut()?;
        Some(profile.at(p, len_mm, snap_mm))
    }

    /// The extra-axis values at dense point `k` of the chain being written
    /// ([`ExtraProfile::at_dense`]); `None` when its moves carry none.
    fn chain_values_at(&mut self, k: usize) -> Option<[f64; 7]> {
        Some(self.chain_extra.as_mut()?.at_dense(k))
    }

    /// Writes `dense` as the longest lines within `tol` ([`crate::chain::simplify`]);
    /// with `lift` and a [`Floor`], short blocks are then lifted against the program.
    #[allow(clippy::too_many_arguments)]
    fn write_lines<W: fmt::Write>(
        &mut self,
        m: &Move,
        dense: &[Vec3],
        hard: &[bool],
        tol: f64,
        dense_acc: f64,
        min_block_mm: f64,
        lift: bool,
        out: &mut W,
    ) -> fmt::Result {
        let mut pts = Vec::with_capacity(dense.len() / 4 + 2);
        let idx = crate::chain::simplify(
            dense,
            hard,
            tol,
            min_block_mm,
            |p| self.rounded(p),
            &mut pts,
        );
        if let Some(p_mm) = self.blend_p_mm.filter(|_| lift) {
            // LinuxCNC's blends: even out the blocks for their radius within `P`, a point
            // moved inside the curve by no more than its blend leaves of `P`.
            let blend = |a: Vec3, b: Vec3, c: Vec3| VertexBlend::new(b - a, c - b, 0.0);
            let how = crate::chain::EvenOut {
                score: |a, b, c| blend(a, b, c).radius_mm(p_mm),
                room: |a, b, c| p_mm - blend(a, b, c).depth_mm(p_mm),
                dense_acc_mm: dense_acc,
            };
            crate::chain::even_out(
                dense,
                hard,
                &idx,
                tol,
                min_block_mm,
                |p| self.rounded(p),
                &how,
                self.written_pos(),
                &mut pts,
            );
        }
        let floor = lift.then(|| self.floor.take()).flatten();
        let mut snapped = Vec::new();
        if let Some(f) = floor.as_ref() {
            let program = f.program_ref();
            let mut how = crate::chain::Lift {
                corners_only: f.corner.is_some(),
                last_block: self.chain_ends.after == RunEnd::Rapid,
                ..Default::default()
            };
            crate::chain::lift_short_blocks_in(
                self.written_pos(),
                &mut pts,
                f.min_block_mm,
                &program,
                &f.grid,
                |p| self.rounded(p),
                &mut how,
            );
            snapped = how.snapped;
        }
        let (shares, splits) = match self.blend_schedule.filter(|_| lift) {
            Some(s) => {
                let start = self.written_pos();
                let rooms = |wanted: &[bool]| match floor.as_ref() {
                    Some(f) => f.rooms(start, &pts, &snapped, wanted),
                    None => Vec::new(),
                };
                self.blocks_blends(s, m, &pts, rooms)
            }
            None => (Vec::new(), Vec::new()),
        };
        if floor.is_some() {
            self.floor = floor;
        }
        for (k, p) in pts.into_iter().enumerate() {
            if let Some(Some(split)) = splits.get(k) {
                self.set_blend_share(split.shares.0);
                let values = self.chain_values(split.point);
                self.linear(m, split.point, values.as_ref(), out)?;
                self.set_blend_share(split.shares.1);
            } else if let Some(&share) = shares.get(k) {
                self.set_blend_share(share);
            }
            let values = self.chain_values(p);
            self.linear(m, p, values.as_ref(), out)?;
        }
        self.set_blend_share(1.0);
        Ok(())
    }

    /// The schedule's share of `P` for each block of the chain `pts` (from the written
    /// position), raised where the rooms of its points (`rooms`, given which points want
    /// one: those whose speed needs all of the run's `P`) allow more than the run's `P`
    /// ([`raise_for_rooms`]), and the blocks it splits.
    fn blocks_blends(
        &self,
        s: BlendSchedule,
        m: &Move,
        pts: &[Vec3],
        rooms: impl FnOnce(&[bool]) -> Vec<Option<VertexRoom>>,
    ) -> (Vec<f64>, Vec<Option<Split>>) {
        let start = self.written_pos();
        let Some(plan) = s.plan(start, pts, m.feed_mm_s, self.chain_ends) else {
            return (Vec::new(), Vec::new());
        };
        let mut shares = plan.block.clone();
        let sharp = |k: usize| {
            let needs_all = BlendSchedule::round_share(*plan.vertex.get(k)?) >= 1.0;
            needs_all.then(|| plan.speed.get(k).copied()).flatten()
        };
        let (first, last) = raised_span(pts.len(), self.chain_ends);
        let wanted: Vec<bool> = (0..pts.len().saturating_sub(1))
            .map(|k| k >= first && k + 1 < last && sharp(k).is_some())
            .collect();
        let rooms = rooms(&wanted);
        raise_for_rooms(&mut shares, &rooms, s.p_mm, self.chain_ends, sharp);
        let splits = s.splits(&plan, start, pts, &shares, |p| self.rounded(p));
        (shares, splits)
    }

    /// Puts the schedule's `G64` for `share` of its `P` before the next line written, when
    /// another is in force ([`MotionWriter::blend_pending`]).
    fn set_blend_share(&mut self, share: f64) {
        let Some(s) = self.blend_schedule else {
            return;
        };
        if share == self.blend_share {
            return;
        }
        self.blend_share = share;
        let text = blend_words(s.p_mm * share, s.q_mm, self.frame.scale, self.decimals());
        self.blend_pending = Some(text);
    }

    /// Writes `dense` as lines and XY arcs within `tol` ([`crate::chain::fit_arcs`]); an
    /// arc the writer cannot carry as `G2`/`G3` is written as lines instead.
    fn write_arc_pieces<W: fmt::Write>(
        &mut self,
        m: &Move,
        dense: &[Vec3],
        hard: &[bool],
        tol: f64,
        out: &mut W,
    ) -> fmt::Result {
        let mut pieces = Vec::with_capacity(dense.len() / 8 + 2);
        crate::chain::fit_arcs(dense, hard, tol, |p| self.rounded(p), &mut pieces);
        for piece in pieces {
            match piece {
                crate::chain::Piece::Line { end, to } => {
                    let values = self.chain_values_at(to);
                    self.linear(m, end, values.as_ref(), out)?
                }
                crate::chain::Piece::Arc {
                    from,
                    to,
                    end,
                    center,
                    ccw,
                } => {
                    let start = self.written_pos();
                    let arc = Arc::from_center(start, end, center, Vec3::Z, ccw, 0);
                    let values = self.chain_values_at(to);
                    let written = match arc {
                        Some(a) => self.try_arc(m, &a, values.as_ref(), out)?,
                        None => false,
                    };
                    if !written {
                        let span = &dense[from..=to];
                        self.write_lines(m, span, &hard[from..=to], tol, 0.0, 0.0, false, out)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// The flattening chord (mm).
    fn chord(&self) -> f64 {
        if self.frame.chord_mm > 0.0 {
            self.frame.chord_mm
        } else {
            DEFAULT_CHORD_MM
        }
    }

    /// Writes one move (lines and native arcs as such, everything else flattened).
    pub(crate) fn write_move<W: fmt::Write>(&mut self, m: &Move, out: &mut W) -> fmt::Result {
        match &m.segment {
            Segment::Line(l) => self.linear(m, l.p1, m.extra.as_ref(), out),
            Segment::Arc(a) => {
                if !self.try_arc(m, a, m.extra.as_ref(), out)? {
                    self.flattened(m, out)?;
                }
                Ok(())
            }
            Segment::Nurbs(n) if self.frame.nurbs => {
                if !self.try_nurbs(m, n, out)? {
                    self.flattened(m, out)?;
                }
                Ok(())
            }
            Segment::CubicBez(b) if self.frame.g5 => {
                if !self.try_g5(m, b, out)? {
                    self.flattened(m, out)?;
                }
                Ok(())
            }
            _ => self.flattened(m, out),
        }
    }

    /// Writes a native arc; false when it must be flattened instead.
    fn try_arc<W: fmt::Write>(
        &mut self,
        m: &Move,
        a: &Arc,
        extra: Option<&[f64; 7]>,
        out: &mut W,
    ) -> Result<bool, fmt::Error> {
        let n = a.normal();
        let close = |v: Vec3| (n - v).norm() <= 1e-9;
        // (plane code, first axis, second axis, G3?)
        let (plane, i0, i1, ccw) = if close(Vec3::Z) {
            (17u8, 0, 1, true)
        } else if close(-Vec3::Z) {
            (17, 0, 1, false)
        } else if close(Vec3::Y) {
            (18, 2, 0, true)
        } else if close(-Vec3::Y) {
            (18, 2, 0, false)
        } else if close(Vec3::X) {
            (19, 1, 2, true)
        } else if close(-Vec3::X) {
            (19, 1, 2, false)
        } else {
            return Ok(false);
        };
        if self.frame.arc_planes & (1 << (plane - 17)) == 0 {
            return Ok(false);
        }
        // A controller that runs the start's circle would leave the spiral by up to its
        // change of radius.
        if !self.frame.spiral_arcs && a.spiral.abs() > 0.5 * self.chord() {
            return Ok(false);
        }
        let unit = self.unit_mm();
        let min_radius = (2.0 * unit).max(MIN_ARC_RADIUS_MM);
        if a.radius.is_nan() || a.radius < min_radius || !a.sweep.is_finite() || a.sweep <= 0.0 {
            return Ok(false);
        }
        let normal_axis = 3 - i0 - i1;
        let chord = {
            let (p, q) = (a.eval(0.0), a.eval(1.0));
            (coord(p, i0) - coord(q, i0)).hypot(coord(p, i1) - coord(q, i1))
        };
        if a.sweep < std::f64::consts::PI
            && chord < (MIN_ARC_CHORD_UNITS * unit).max(MIN_ARC_CHORD_MM)
        {
            return Ok(false);
        }
        // An arc needs both axes of its plane (and the normal one for a helix) writable,
        // and no diameter-mode X.
        let helix = (coord(a.eval(1.0), normal_axis) - coord(a.eval(0.0), normal_axis)).abs() > 0.0;
        if !self.allowed(i0)
            || !self.allowed(i1)
            || (helix && !self.allowed(normal_axis))
            || self.frame.diameter
        {
            return Ok(false);
        }
        let turns = ((a.sweep / TAU) - 1e-9).ceil().max(1.0);
        if turns > 10_000.0 {
            return Ok(false);
        }
        let full = (a.sweep - turns * TAU).abs() <= 1e-9 * turns;
        let mut end = a.eval(1.0);
        let start_written = self.written_pos();
        if full {
            // End exactly where the reader's start is, in the plane.
            set_coord(&mut end, i0, coord(start_written, i0));
            set_coord(&mut end, i1, coord(start_written, i1));
        } else {
            // Would rounding make start and end coincide (a full circle for the reader)?
            let s0 = self.mm_to_units(i0, coord(end, i0));
            self.fmt(s0);
            let e0: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            let s1 = self.mm_to_units(i1, coord(end, i1));
            self.fmt(s1);
            let e1: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            let w0 = self.mm_to_units(i0, coord(start_written, i0));
            let w1 = self.mm_to_units(i1, coord(start_written, i1));
            self.fmt(w0);
            let w0: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            self.fmt(w1);
            let w1: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            if e0 == w0 && e1 == w1 {
                return Ok(false);
            }
        }
        self.begin();
        if plane != self.frame.plane {
            let _ = write!(self.line, "G{plane} ");
            self.frame.plane = plane;
        }
        self.line.push_str(if ccw { "G3" } else { "G2" });
        self.exact_now = if full { None } else { self.exact_at(end) };
        for i in 0..3 {
            if i == normal_axis && !self.allowed(i) {
                continue;
            }
            let force = i != normal_axis || !self.axis_known[i];
            self.axis(i, coord(end, i), force);
        }
        self.exact_now = None;
        const CENTRE: [char; 3] = ['I', 'J', 'K'];
        for i in [0, 1, 2] {
            if i == normal_axis {
                continue;
            }
            let c = if self.frame.arc_absolute {
                coord(a.center, i)
            } else {
                coord(a.center, i) - coord(start_written, i)
            };
            self.push_fine(CENTRE[i], c);
        }
        if turns > 1.0 {
            let _ = write!(self.line, " P{}", turns as u64);
        }
        self.extras(extra);
        self.feed(m);
        self.last_motion = Some(if ccw { 3 } else { 2 });
        self.end(out)?;
        Ok(true)
    }

    fn flattened<W: fmt::Write>(&mut self, m: &Move, out: &mut W) -> fmt::Result {
        let mut pts = std::mem::take(&mut self.points);
        pts.clear();
        let start = m.segment.start();
        pts.push(start);
        let chord = self.chord();
        m.segment.flatten(chord, &mut |p| pts.push(p));
        // Extra axes: interpolate from the previous values by cumulative chord length.
        let total: f64 = pts.windows(2).map(|w| w[0].dist(w[1])).sum();
        let e0 = self.program_extra();
        let mut acc = 0.0;
        let mut r = Ok(());
        for k in 1..pts.len() {
            acc += pts[k - 1].dist(pts[k]);
            let extra = m.extra.map(|e1| {
                if k + 1 == pts.len() || total <= 0.0 {
                    e1
                } else {
                    let t = acc / total;
                    std::array::from_fn(|i| e0[i] + (e1[i] - e0[i]) * t)
                }
            });
            r = self.linear(m, pts[k], extra.as_ref(), out);
            if r.is_err() {
                break;
            }
        }
        self.points = pts;
        r
    }
}

#[cfg(test)]
mod tests {
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
        let c = crate::rewrite::CornerBlend {
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

    #[test]
    fn numbers() {
        let f = |v: f64, d: usize| {
            let mut s = String::new();
            push_fixed(&mut s, v, d);
            s
        };
        assert_eq!(f(1.5, 4), "1.5");
        assert_eq!(f(-0.00001, 4), "0");
        assert_eq!(f(-0.0, 4), "0");
        assert_eq!(f(10.0, 4), "10");
        assert_eq!(f(100.0, 0), "100");
        assert_eq!(f(1e20, 2), "100000000000000000000");
        assert_eq!(f(-2.25, 1), "-2.3"); // ties away from zero
        assert_eq!(f(1234.56789, 6), "1234.56789");
        assert_eq!(f(0.05, 4), "0.05");
        assert_eq!(f(-0.000123, 6), "-0.000123");
        assert_eq!(f(3.0001, 4), "3.0001");
        assert_eq!(f(1e300, 4).len(), 301); // slow path, no exponent
        assert_eq!(f(-1e300, 2).chars().next(), Some('-'));
        // Agrees with exact formatting away from ties.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..10_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = (state % 2_000_000_000) as f64 / 1e4 - 1e5 + 0.123_456_789;
            let mut exact = format!("{v:.4}");
            while exact.contains('.') && (exact.ends_with('0') || exact.ends_with('.')) {
                exact.pop();
            }
            assert_eq!(f(v, 4), exact);
        }
    }
}
