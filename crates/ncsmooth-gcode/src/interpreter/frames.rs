//! Where the tool is, and what is known of it.
//!
//! LinuxCNC places a work position `p` (what the program writes) on the machine as
//!
//! ```text
//! machine = rotate_xy(p + g92, R) + g5x + tool
//! ```
//!
//! with `g92` the G92/G52 offset, `R` the XY rotation and `g5x` the offset of the active
//! coordinate system (G54..G59.3, set by G10 L2/L20), and `tool` the tool length offset
//! (G43, G43.1, G43.2, G49). ncsmooth does not know the stored offsets, the tool table or
//! the home positions (G28/G30) of the machine that will run the program, so each of them
//! is an `Option`: `None` until the program itself sets it. The work position of each
//! axis is known or not (`Frames::known`):
//!
//! * at the start nothing is known; an axis becomes known when the program commands it
//!   (an absolute axis word in the current frame, or `G92`/`G10 L20` naming it);
//! * whenever a term of the formula changes for an axis (a coordinate-system change, G10
//!   on the active system, G92.x, G52, a tool-length change, a G53 move, a G28/G30
//!   return), the new work position is recomputed through the machine position, and is
//!   unknown unless every term before and after is known.
//!
//! An unknown axis keeps a placeholder value in `Frames::pos` (its last known value, or
//! 0), used only as a constant coordinate of the geometry of moves that do not move it;
//! writers never write it.
//!
//! A [`MachineModel`] makes everything known (LinuxCNC's standalone interpreter starts at
//! machine zero with the offsets of its parameter file and its tool table): that is how
//! the conformance tests compare with LinuxCNC's canonical output.

use std::collections::HashMap;

/// Axes tracked: X Y Z A B C U V W.
pub(crate) const N_AXES: usize = 9;
/// Letters of the axes, in storage order.
pub(crate) const AXIS_LETTERS: [u8; N_AXES] = *b"XYZABCUVW";
/// All axes.
pub(crate) const ALL_AXES: u16 = (1 << N_AXES) - 1;
/// Number of coordinate systems (G54, G55, G56, G57, G58, G59, G59.1, G59.2, G59.3).
pub(crate) const N_SYSTEMS: usize = 9;

/// A value per axis.
pub(crate) type Axes = [f64; N_AXES];
/// A value per axis, each possibly unknown.
pub(crate) type MaybeAxes = [Option<f64>; N_AXES];

/// Bit of axis `i`.
#[inline]
pub(crate) const fn bit(i: usize) -> u16 {
    1 << i
}

/// Machine state for a run where it is known (tests against LinuxCNC's interpreter, which
/// reads it from its parameter file and tool table). Lengths in mm, angles in degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineModel {
    /// Offsets of G54..G59.3.
    pub g5x: [[f64; N_AXES]; N_SYSTEMS],
    /// XY rotation of each coordinate system (degrees).
    pub rotation: [f64; N_SYSTEMS],
    /// Active coordinate system (0 = G54).
    pub active: usize,
    /// G92 offset in force at the start.
    pub g92: [f64; N_AXES],
    /// Tool table: offsets per tool number.
    pub tools: HashMap<u32, [f64; N_AXES]>,
    /// G28 and G30 home positions (machine coordinates).
    pub home: [[f64; N_AXES]; 2],
    /// Machine position at the start.
    pub start: [f64; N_AXES],
    /// Units of the stored parameters (`#5161..#5390`): LinuxCNC keeps them in the
    /// machine's units (inch for the standalone interpreter), not the program's.
    pub machine_units: ncsmooth::path::Units,
}

impl Default for MachineModel {
    /// LinuxCNC's standalone interpreter without a parameter file: every offset zero, at
    /// machine zero, G54 active, empty tool table.
    fn default() -> Self {
        MachineModel {
            g5x: [[0.0; N_AXES]; N_SYSTEMS],
            rotation: [0.0; N_SYSTEMS],
            active: 0,
            g92: [0.0; N_AXES],
            tools: HashMap::new(),
            home: [[0.0; N_AXES]; 2],
            start: [0.0; N_AXES],
            machine_units: ncsmooth::path::Units::Millimetres,
        }
    }
}

/// Positions and offsets.
#[derive(Clone, Debug)]
pub(crate) struct Frames {
    /// Work position (mm, degrees for A B C); a placeholder where not known.
    pub pos: Axes,
    /// Bit `i` set when axis `i`'s work position is known.
    pub known: u16,
    /// Bit `i` set when axis `i`'s position is known only relative to a point the program
    /// never placed (never in `known`): incremental moves from an unknown position (a
    /// laser program run from wherever the head is) keep `pos` as where they went from a
    /// placeholder start. Such an axis is written only in increments, and becomes unknown
    /// at any change of frame or an absolute word (see [`Frames::set`]).
    pub relative: u16,
    g5x: [MaybeAxes; N_SYSTEMS],
    rot: [Option<f64>; N_SYSTEMS],
    /// Active coordinate system, if known.
    pub active: Option<usize>,
    /// G92/G52 offset applied.
    pub g92: MaybeAxes,
    /// `#5211..#5219`: the G92 offset as stored for G92.3.
    pub g92_saved: MaybeAxes,
    /// `#5210`: G92 (or G52) applied; LinuxCNC sets it with G92, G52 and G92.3 (also to
    /// zero offsets) and clears it with G92.1 and G92.2.
    pub g92_applied: Option<bool>,
    /// Tool length offset applied.
    pub tool: MaybeAxes,
    /// Tool table (known machine only).
    tools: Option<HashMap<u32, [f64; N_AXES]>>,
    /// Millimetres per unit of the stored parameters.
    pub machine_scale: f64,
    /// G28 and G30 positions (machine coordinates).
    pub home: [MaybeAxes; 2],
}

fn some_all(v: &[f64; N_AXES]) -> MaybeAxes {
    v.map(Some)
}

impl Frames {
    /// Nothing known.
    pub(crate) fn unknown() -> Frames {
        Frames {
            pos: [0.0; N_AXES],
            known: 0,
            relative: 0,
            g5x: [[None; N_AXES]; N_SYSTEMS],
            rot: [None; N_SYSTEMS],
            active: None,
            g92: [None; N_AXES],
            g92_saved: [None; N_AXES],
            g92_applied: None,
            tool: [None; N_AXES],
            tools: None,
            home: [[None; N_AXES]; 2],
            machine_scale: 1.0,
        }
    }

    /// Everything known, from `m`.
    pub(crate) fn known(m: &MachineModel) -> Frames {
        let mut f = Frames {
            pos: [0.0; N_AXES],
            known: 0,
            relative: 0,
            g5x: m.g5x.map(|o| some_all(&o)),
            rot: m.rotation.map(Some),
            active: Some(m.active.min(N_SYSTEMS - 1)),
            g92: some_all(&m.g92),
            g92_saved: some_all(&m.g92),
            g92_applied: Some(m.g92.iter().any(|&o| o != 0.0)),
            tool: [Some(0.0); N_AXES],
            tools: Some(m.tools.clone()),
            home: [some_all(&m.home[0]), some_all(&m.home[1])],
            machine_scale: match m.machine_units {
                ncsmooth::path::Units::Millimetres => 1.0,
                ncsmooth::path::Units::Inches => 25.4,
            },
        };
        f.set_from_machine(&some_all(&m.start), ALL_AXES);
        f
    }

    /// Whether every axis in `mask` is known.
    #[inline]
    pub(crate) fn all_known(&self, mask: u16) -> bool {
        self.known & mask == mask
    }

    /// The work position of axis `i`, if known.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> Option<f64> {
        (self.known & bit(i) != 0).then_some(self.pos[i])
    }

    /// The position of axis `i` relative to its placeholder start, if that is how it is
    /// known ([`Frames::relative`]).
    #[inline]
    pub(crate) fn get_relative(&self, i: usize) -> Option<f64> {
        (self.relative & bit(i) != 0).then_some(self.pos[i])
    }

    /// Axis `i` is at `v` relative to its placeholder start ([`Frames::relative`]).
    pub(crate) fn set_relative(&mut self, i: usize, v: f64) {
        if v.is_finite() {
            self.pos[i] = v;
            self.relative |= bit(i);
            self.known &= !bit(i);
        } else {
            self.set(i, None);
        }
    }

    /// Sets axis `i` to `v` (unknown when `v` is `None`, keeping the placeholder); either
    /// way it is no longer known relatively.
    #[inline]
    pub(crate) fn set(&mut self, i: usize, v: Option<f64>) {
        self.relative &= !bit(i);
        match v {
            Some(x) if x.is_finite() => {
                self.pos[i] = x;
                self.known |= bit(i);
            }
            _ => self.known &= !bit(i),
        }
    }

    /// XY rotation of the active system (degrees), if known.
    pub(crate) fn rotation(&self) -> Option<f64> {
        self.rot[self.active?]
    }

    /// Offset of the active coordinate system, axis `i`.
    fn g5x_active(&self, i: usize) -> Option<f64> {
        self.g5x[self.active?][i]
    }

    /// The offset of coordinate system `k` (0 = G54), axis `i` (for `#5221..`).
    pub(crate) fn g5x_of(&self, k: usize, i: usize) -> Option<f64> {
        self.g5x.get(k)?.get(i).copied().flatten()
    }

    /// The XY rotation of system `k`.
    pub(crate) fn rotation_of(&self, k: usize) -> Option<f64> {
        self.rot.get(k).copied().flatten()
    }

    /// Work position + G92 offset, then rotated: the part of the machine position before
    /// the coordinate-system and tool offsets, per axis.
    fn rotated(&self) -> MaybeAxes {
        let mut q: MaybeAxes = std::array::from_fn(|i| Some(self.get(i)? + self.g92[i]?));
        match self.rotation() {
            Some(0.0) => {}
            Some(r) => {
                let (s, c) = r.to_radians().sin_cos();
                let (x, y) = (q[0], q[1]);
                q[0] = x.zip(y).map(|(x, y)| x * c - y * s);
                q[1] = x.zip(y).map(|(x, y)| x * s + y * c);
            }
            None => {
                q[0] = None;
                q[1] = None;
            }
        }
        q
    }

    /// The machine position, per axis, where known.
    pub(crate) fn machine(&self) -> MaybeAxes {
        let q = self.rotated();
        std::array::from_fn(|i| Some(q[i]? + self.g5x_active(i)? + self.tool[i]?))
    }

    /// Sets the work position of the axes in `mask` from machine position `m`.
    pub(crate) fn set_from_machine(&mut self, m: &MaybeAxes, mask: u16) {
        // Undo the tool and coordinate-system offsets, the rotation, then G92.
        let mut q: MaybeAxes =
            std::array::from_fn(|i| Some(m[i]? - self.g5x_active(i)? - self.tool[i]?));
        match self.rotation() {
            Some(0.0) => {}
            Some(r) => {
                let (s, c) = r.to_radians().sin_cos();
                let (x, y) = (q[0], q[1]);
                q[0] = x.zip(y).map(|(x, y)| x * c + y * s);
                q[1] = x.zip(y).map(|(x, y)| -x * s + y * c);
            }
            None => {
                q[0] = None;
                q[1] = None;
            }
        }
        for i in 0..N_AXES {
            if mask & bit(i) != 0 {
                self.set(i, q[i].zip(self.g92[i]).map(|(q, o)| q - o));
            }
        }
    }

    /// Applies a change of the offsets (`f`) that moves the frame of the axes in `mask`
    /// under the tool: their work positions are recomputed through the machine position.
    /// A rotation couples X and Y.
    pub(crate) fn reframe(&mut self, mut mask: u16, f: impl FnOnce(&mut Frames)) {
        if mask & 0b11 != 0 {
            mask |= 0b11;
        }
        let m = self.machine();
        f(self);
        self.set_from_machine(&m, mask);
    }

    /// Selects coordinate system `k` (G54 = 0).
    pub(crate) fn select_system(&mut self, k: usize) {
        if self.active == Some(k) {
            return;
        }
        self.reframe(ALL_AXES, |f| f.active = Some(k));
    }

    /// G10 L2: offsets of system `target` (`None`: the active one, or an unknown one) set
    /// to `vals` (machine coordinates), and its rotation to `r`.
    pub(crate) fn g10_l2(&mut self, target: Option<usize>, vals: &MaybeAxes, r: Option<f64>) {
        let given: u16 = (0..N_AXES)
            .filter(|&i| vals[i].is_some())
            .fold(0, |m, i| m | bit(i));
        let active = target.is_some() && target == self.active;
        let mask = if active || self.active.is_none() || target.is_none() {
            given | if r.is_some() { 0b11 } else { 0 }
        } else {
            0
        };
        self.reframe(mask, |f| match target {
            Some(k) => {
                for i in 0..N_AXES {
                    if let Some(v) = vals[i] {
                        f.g5x[k][i] = Some(v);
                    }
                }
                if r.is_some() {
                    f.rot[k] = r;
                }
            }
            None => {
                // Which system changed is unknown: every system's value is now unknown.
                for k in 0..N_SYSTEMS {
                    for i in 0..N_AXES {
                        if vals[i].is_some() {
                            f.g5x[k][i] = None;
                        }
                    }
                    if r.is_some() {
                        f.rot[k] = None;
                    }
                }
            }
        });
    }

    /// G10 L20: system `target`'s offsets set so that the current position reads `vals`
    /// (an axis not given keeps its reading; under an XY rotation X and Y are set together).
    pub(crate) fn g10_l20(&mut self, target: Option<usize>, vals: &MaybeAxes) {
        let m = self.machine();
        let active = target.is_some() && target == self.active;
        let rot = target.and_then(|k| self.rot[k]);
        // The value each given axis (and its XY partner) will read.
        let mut want: MaybeAxes = *vals;
        let xy = vals[0].is_some() || vals[1].is_some();
        if xy {
            for i in 0..2 {
                if want[i].is_none() {
                    // The partner keeps its current reading in the target system.
                    want[i] = if active { self.get(i) } else { None };
                }
            }
        }
        let q: MaybeAxes = std::array::from_fn(|i| Some(want[i]? + self.g92[i]?));
        let mut off: MaybeAxes = std::array::from_fn(|i| Some(m[i]? - q[i]? - self.tool[i]?));
        if xy {
            let r = rot.zip(q[0]).zip(q[1]).map(|((r, x), y)| {
                let (s, c) = r.to_radians().sin_cos();
                (x * c - y * s, x * s + y * c)
            });
            for i in 0..2 {
                off[i] = r.and_then(|(x, y)| {
                    let v = if i == 0 { x } else { y };
                    Some(m[i]? - v - self.tool[i]?)
                });
            }
        }
        let set_mask = (0..N_AXES)
            .filter(|&i| vals[i].is_some() || (xy && i < 2))
            .fold(0u16, |a, i| a | bit(i));
        for i in 0..N_AXES {
            if set_mask & bit(i) == 0 {
                continue;
            }
            match target {
                Some(k) => self.g5x[k][i] = off[i],
                None => {
                    for k in 0..N_SYSTEMS {
                        self.g5x[k][i] = None;
                    }
                }
            }
            if active {
                self.set(i, want[i]);
            } else if self.active.is_none() || target.is_none() {
                self.set(i, None);
            }
        }
    }

    /// G92: the current position of the given axes becomes `vals`.
    pub(crate) fn g92(&mut self, vals: &MaybeAxes) {
        for i in 0..N_AXES {
            let Some(v) = vals[i] else { continue };
            // work + g92 is what the machine sees before rotation: it stays.
            let before = self.get(i).zip(self.g92[i]).map(|(p, o)| p + o);
            self.g92[i] = before.map(|b| b - v);
            self.set(i, Some(v));
        }
        // LinuxCNC stores every axis's offset in #5211..#5219.
        self.g92_saved = self.g92;
        self.g92_applied = Some(true);
    }

    /// G92.1 (`clear_saved`) / G92.2: the G92 offset cancelled.
    pub(crate) fn g92_cancel(&mut self, clear_saved: bool) {
        self.reframe(ALL_AXES, |f| {
            f.g92 = [Some(0.0); N_AXES];
            if clear_saved {
                f.g92_saved = [Some(0.0); N_AXES];
            }
        });
        self.g92_applied = Some(false);
    }

    /// G92.3: the saved G92 offset applied again.
    pub(crate) fn g92_restore(&mut self) {
        self.reframe(ALL_AXES, |f| f.g92 = f.g92_saved);
        self.g92_applied = Some(true);
    }

    /// G52: the local offset of the given axes set to `vals`.
    pub(crate) fn g52(&mut self, vals: &MaybeAxes) {
        let given: u16 = (0..N_AXES)
            .filter(|&i| vals[i].is_some())
            .fold(0, |m, i| m | bit(i));
        self.reframe(given, |f| {
            for i in 0..N_AXES {
                if vals[i].is_some() {
                    f.g92[i] = vals[i];
                }
            }
        });
        self.g92_saved = self.g92;
        self.g92_applied = Some(true);
    }

    /// The offsets of tool `n` from the tool table, if known.
    pub(crate) fn tool_entry(&self, n: u32) -> MaybeAxes {
        match &self.tools {
            Some(t) => match t.get(&n) {
                Some(v) => some_all(v),
                None => [Some(0.0); N_AXES],
            },
            None => [None; N_AXES],
        }
    }

    /// Sets a tool table entry's given axes (G10 L1/L10/L11).
    pub(crate) fn set_tool_entry(&mut self, n: u32, vals: &MaybeAxes) {
        let Some(t) = &mut self.tools else { return };
        let e = t.entry(n).or_insert([0.0; N_AXES]);
        for i in 0..N_AXES {
            if let Some(v) = vals[i] {
                e[i] = v;
            }
        }
    }

    /// Forgets the tool table (G10 L1 with values ncsmooth cannot know).
    pub(crate) fn forget_tools(&mut self) {
        self.tools = None;
    }

    /// G10 L10 (`fixture`: `None`) / L11 (`Some(k)`: the touch-off fixture, system `k`,
    /// whose origin G92 does not move): the new entry of tool `n` that makes the current
    /// position read `vals` in that frame, as LinuxCNC's `convert_setup_tool` computes it
    /// (under an XY rotation a single X or Y keeps the entry's component along the other
    /// rotated axis). `None` where something it needs is unknown.
    pub(crate) fn tool_touch_off(
        &self,
        n: u32,
        vals: &MaybeAxes,
        fixture: Option<usize>,
    ) -> Option<MaybeAxes> {
        let m = self.machine();
        let sys = match fixture {
            Some(k) => k,
            None => self.active?,
        };
        let r = self.rot[sys]?;
        let (s, c) = r.to_radians().sin_cos();
        let rot = |x: f64, y: f64| (x * c - y * s, x * s + y * c);
        let unrot = |x: f64, y: f64| (x * c + y * s, -x * s + y * c);
        let g92 = |i: usize| {
            if fixture.is_some() {
                Some(0.0)
            } else {
                self.g92[i]
            }
        };
        // The current position in that system, without the tool length offset.
        let q: MaybeAxes = std::array::from_fn(|i| Some(m[i]? - self.tool[i]? - self.g5x[sys][i]?));
        let mut t: MaybeAxes = std::array::from_fn(|i| Some(q[i]? - g92(i)?));
        let (tx, ty) = unrot(q[0]?, q[1]?);
        t[0] = Some(tx - g92(0)?);
        t[1] = Some(ty - g92(1)?);
        let old = self.tool_entry(n);
        let mut e: MaybeAxes = [None; N_AXES];
        for i in 2..N_AXES {
            if let Some(v) = vals[i] {
                e[i] = Some(t[i]? - v);
            }
        }
        let (tx, ty) = (t[0]?, t[1]?);
        match (vals[0], vals[1]) {
            (Some(x), Some(y)) => {
                let (a, b) = rot(tx - x, ty - y);
                e[0] = Some(a);
                e[1] = Some(b);
            }
            (Some(x), None) => {
                let (_, oy) = unrot(old[0]?, old[1]?);
                let (ox, oy) = rot(0.0, oy);
                let (a, b) = rot(tx - x, 0.0);
                e[0] = Some(a + ox);
                e[1] = Some(b + oy);
            }
            (None, Some(y)) => {
                let (ox, _) = unrot(old[0]?, old[1]?);
                let (ox, oy) = rot(ox, 0.0);
                let (a, b) = rot(0.0, ty - y);
                e[0] = Some(a + ox);
                e[1] = Some(b + oy);
            }
            (None, None) => {}
        }
        Some(e)
    }

    /// Sets the tool length offset (G43 H, G43.1, G43.2, G49).
    pub(crate) fn set_tool_offset(&mut self, t: MaybeAxes) {
        self.reframe(ALL_AXES, |f| f.tool = t);
    }

    /// The work positions of the axes in `mask` become unknown (the machine moved where
    /// ncsmooth cannot follow: a tool change position, a probe).
    pub(crate) fn forget(&mut self, mask: u16) {
        self.known &= !mask;
        self.relative &= !mask;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vals(pairs: &[(usize, f64)]) -> MaybeAxes {
        let mut v = [None; N_AXES];
        for &(i, x) in pairs {
            v[i] = Some(x);
        }
        v
    }

    #[test]
    fn unknown_machine_forgets_on_frame_changes() {
        let mut f = Frames::unknown();
        for i in 0..3 {
            f.set(i, Some(1.0 + i as f64));
        }
        assert!(f.all_known(0b111));
        f.select_system(1);
        assert_eq!(f.known, 0, "G55 with unknown offsets");
        f.set(0, Some(5.0));
        f.g92(&vals(&[(1, 0.0)]));
        assert_eq!(f.get(1), Some(0.0), "G92 Y0 makes Y known");
        assert_eq!(f.get(0), Some(5.0), "G92 leaves X");
        f.g92_cancel(true);
        assert_eq!(f.known, 0, "G92.1 with an unknown G92 offset before");
        f.set(2, Some(3.0));
        f.set_tool_offset([Some(0.0); N_AXES]);
        assert_eq!(f.get(2), None, "G49 after an unknown tool offset");
    }

    #[test]
    fn known_machine_follows_every_offset() {
        let mut m = MachineModel::default();
        m.g5x[1][0] = 10.0;
        let mut f = Frames::known(&m);
        assert_eq!(f.get(0), Some(0.0));
        f.select_system(1);
        assert_eq!(f.get(0), Some(-10.0));
        f.g92(&vals(&[(0, 0.0)]));
        assert_eq!(f.get(0), Some(0.0));
        f.g92_cancel(false);
        assert_eq!(f.get(0), Some(-10.0));
        f.g92_restore();
        assert_eq!(f.get(0), Some(0.0));
        // G10 L20 on the active system: the position reads the value, the offset follows.
        f.g10_l20(Some(1), &vals(&[(1, 2.0)]));
        assert_eq!(f.get(1), Some(2.0));
        assert_eq!(f.machine()[1], Some(0.0));
        // Rotation: machine stays, work coordinates rotate.
        f.g92_cancel(true);
        f.set(0, Some(1.0));
        f.set(1, Some(0.0));
        let before = f.machine();
        f.g10_l2(Some(1), &[None; N_AXES], Some(90.0));
        let after = f.machine();
        for i in 0..2 {
            assert!((before[i].unwrap() - after[i].unwrap()).abs() < 1e-12);
        }
    }

    #[test]
    fn other_systems_change_nothing() {
        let mut f = Frames::unknown();
        f.select_system(0);
        f.set(0, Some(1.0));
        f.g10_l2(Some(3), &vals(&[(0, 7.0)]), None);
        assert_eq!(f.get(0), Some(1.0));
        f.g10_l2(Some(0), &vals(&[(0, 7.0)]), None);
        assert_eq!(f.get(0), None);
    }
}
