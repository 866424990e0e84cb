//! Random valid LinuxCNC programs for the differential test against `rs274`: each seed gives
//! one program that LinuxCNC's interpreter accepts, mixing what a reader gets wrong first:
//! micro-line runs to smooth (absolute and G91), centre-format arcs in G17, G18 and G19
//! whose end is off the start's circle by up to half LinuxCNC's radius tolerance (a
//! spiral), near-full circles, multi-turn and helical arcs, R-format arcs, canned cycles
//! in G90 and G91 (with `L` repeats), inch and millimetre units, and non-motion events
//! (spindle, coolant, dwell, comments) between them.

/// splitmix64: a fixed sequence per seed, the same on every machine.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x5851_f42d_4c95_7f2d)
    }
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }
}

/// The in-plane axes and the normal of a plane (0 = G17 XY, 1 = G18 ZX, 2 = G19 YZ), with
/// the letters of its centre words, as LinuxCNC orders them.
const PLANES: [(usize, usize, usize, &str); 3] =
    [(0, 1, 2, "G17"), (2, 0, 1, "G18"), (1, 2, 0, "G19")];
const AXES: [char; 3] = ['X', 'Y', 'Z'];
const CENTRE: [char; 3] = ['I', 'J', 'K'];

/// LinuxCNC's absolute start/end radius tolerance of a centre-format arc, in mm
/// (`CENTER_ARC_RADIUS_TOLERANCE_MM`); a tenth of it in inch programs, as there.
const SPIRAL_TOL_MM: f64 = 2.0 * 0.01 * std::f64::consts::SQRT_2;

struct Gen {
    rng: Rng,
    /// Program units per mm.
    per_mm: f64,
    /// Decimals written.
    decimals: usize,
    /// Absolute position (program units).
    pos: [f64; 3],
    incremental: bool,
    plane: usize,
    text: String,
}

impl Gen {
    fn num(&self, v: f64) -> String {
        let s = format!("{:.*}", self.decimals, v);
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" || s.is_empty() {
            "0".into()
        } else {
            s.into()
        }
    }
    /// Rounds a position to what is written.
    fn round(&self, v: f64) -> f64 {
        let k = 10f64.powi(self.decimals as i32);
        (v * k).round() / k
    }
    fn line(&mut self, s: &str) {
        self.text.push_str(s);
        self.text.push('\n');
    }
    fn mm(&self, v: f64) -> f64 {
        v * self.per_mm
    }
    /// A length uniform in `[lo, hi)` mm, in program units.
    fn rmm(&mut self, lo: f64, hi: f64) -> f64 {
        let v = self.rng.range(lo, hi);
        self.mm(v)
    }
    fn set_mode(&mut self, incremental: bool) {
        if incremental != self.incremental {
            self.incremental = incremental;
            self.line(if incremental { "G91" } else { "G90" });
        }
    }
    fn set_plane(&mut self, plane: usize) {
        if plane != self.plane {
            self.plane = plane;
            self.line(PLANES[plane].3);
        }
    }
    /// The axis words moving to `target` (absolute, program units, already rounded).
    fn axis_words(&self, target: [f64; 3], all: bool) -> String {
        let mut w = String::new();
        for i in 0..3 {
            let v = if self.incremental {
                target[i] - self.pos[i]
            } else {
                target[i]
            };
            if all || (target[i] - self.pos[i]).abs() > 0.0 {
                w += &format!(" {}{}", AXES[i], self.num(v));
            }
        }
        w
    }
    fn go(&mut self, code: &str, target: [f64; 3], tail: &str) {
        let t = target.map(|v| self.round(v));
        let words = self.axis_words(t, false);
        if words.is_empty() {
            return;
        }
        self.line(&format!("{code}{words}{tail}"));
        self.pos = t;
    }

    /// A run of micro-lines in the current plane: a wavy stroke with corners.
    fn micro_lines(&mut self) {
        let (a, b, _, _) = PLANES[self.plane];
        let n = 15 + self.rng.below(60);
        let step = self.rmm(0.15, 1.2);
        let mut heading = self.rng.range(0.0, std::f64::consts::TAU);
        let bend = self.rng.range(-0.4, 0.4);
        for k in 0..n {
            heading += bend
                + if k % 7 == 3 {
                    self.rng.range(-1.5, 1.5)
                } else {
                    0.0
                };
            let mut t = self.pos;
            t[a] += step * heading.cos();
            t[b] += step * heading.sin();
            self.go("G1", t, "");
        }
    }

    /// A centre-format arc from the current point about a centre at `radius` (mm), turning
    /// `sweep` (rad), its end radius off by `spiral` (mm), rising `rise` (mm) along the
    /// plane's normal, with `turns` full turns more.
    fn arc(&mut self, radius: f64, sweep: f64, ccw: bool, spiral: f64, rise: f64, turns: u32) {
        let (a, b, n, _) = PLANES[self.plane];
        let start = self.pos;
        let phi0 = self.rng.range(0.0, std::f64::consts::TAU);
        let r = self.mm(radius);
        let centre = [start[a] - r * phi0.cos(), start[b] - r * phi0.sin()];
        let phi1 = phi0 + if ccw { sweep } else { -sweep };
        let r1 = r + self.mm(spiral);
        let mut end = start;
        end[a] = centre[0] + r1 * phi1.cos();
        end[b] = centre[1] + r1 * phi1.sin();
        end[n] += self.mm(rise);
        let end = end.map(|v| self.round(v));
        let mut words = self.axis_words(end, true);
        let (ia, ib) = (centre[0] - start[a], centre[1] - start[b]);
        words += &format!(" {}{}", CENTRE[a], self.num(ia));
        words += &format!(" {}{}", CENTRE[b], self.num(ib));
        if turns > 0 {
            words += &format!(" P{}", turns + 1);
        }
        self.line(&format!("{}{words}", if ccw { "G3" } else { "G2" }));
        self.pos = end;
    }

    /// An R-format arc of radius `radius` (mm) through a chord of `share` of its diameter.
    fn r_arc(&mut self, radius: f64, share: f64, ccw: bool, long_way: bool) {
        let (a, b, _, _) = PLANES[self.plane];
        let chord = self.mm(2.0 * radius * share);
        let dir = self.rng.range(0.0, std::f64::consts::TAU);
        let mut end = self.pos;
        end[a] += chord * dir.cos();
        end[b] += chord * dir.sin();
        let end = end.map(|v| self.round(v));
        let words = self.axis_words(end, true);
        let r = self.mm(radius) * if long_way { -1.0 } else { 1.0 };
        let code = if ccw { "G3" } else { "G2" };
        self.line(&format!("{code}{words} R{}", self.num(r)));
        self.pos = end;
    }

    /// One to four arcs of the kinds the reader must get right.
    fn arcs(&mut self) {
        let tol = SPIRAL_TOL_MM * 0.5 * if self.per_mm < 1.0 { 0.1 } else { 1.0 };
        for _ in 0..1 + self.rng.below(4) {
            let ccw = self.rng.chance(0.5);
            let spiral = if self.rng.chance(0.7) {
                self.rng.range(-tol, tol)
            } else {
                0.0
            };
            match self.rng.below(6) {
                // Near-full circle: the end a few micrometres to a few tenths from the start.
                0 => {
                    let radius = self.rng.range(0.5, 15.0);
                    let gap = self.rng.range(0.002, 0.3) / radius;
                    self.arc(radius, std::f64::consts::TAU - gap, ccw, spiral, 0.0, 0);
                }
                // Small arcs.
                1 => {
                    let radius = self.rng.range(0.05, 0.6);
                    let sweep = self.rng.range(0.3, 5.5);
                    self.arc(radius, sweep, ccw, spiral * 0.2, 0.0, 0);
                }
                // Helical, sometimes with extra turns.
                2 => {
                    let radius = self.rng.range(1.0, 8.0);
                    let turns = u32::from(self.rng.chance(0.3));
                    let rise = self.rng.range(-2.0, 2.0);
                    let sweep = self.rng.range(0.5, 6.0);
                    self.arc(radius, sweep, ccw, spiral, rise, turns);
                }
                3 => {
                    let radius = self.rng.range(0.5, 20.0);
                    let share = self.rng.range(0.1, 0.95);
                    let long = self.rng.chance(0.3);
                    self.r_arc(radius, share, ccw, long);
                }
                _ => {
                    let radius = self.rng.range(1.0, 30.0);
                    let sweep = self.rng.range(0.2, 6.2);
                    self.arc(radius, sweep, ccw, spiral, 0.0, 0);
                }
            }
        }
    }

    /// A drilling cycle (G81, G82, G83 or G73) over two to four holes, in G90 or G91 (with
    /// an `L` repeat), retracting to the old Z (G98) or to R (G99), then G80.
    fn cycle(&mut self) {
        self.set_plane(0);
        let code = ["G81", "G82", "G83", "G73"][self.rng.below(4)];
        let retract = if self.rng.chance(0.5) { "G98" } else { "G99" };
        let feed = {
            let v = self.rmm(100.0, 400.0);
            self.num(v)
        };
        let extra = match code {
            "G82" => " P0.2".to_string(),
            "G83" | "G73" => format!(" Q{}", {
                let v = self.rmm(0.5, 2.0);
                self.num(v)
            }),
            _ => String::new(),
        };
        let depth = self.rmm(1.0, 4.0);
        let clear = self.rmm(0.5, 2.0);
        if self.rng.chance(0.5) {
            // G91: R is the distance from the current Z to the R plane, Z from R down.
            self.set_mode(true);
            let (dx, dy) = (self.rmm(2.0, 6.0), self.rmm(-3.0, 3.0));
            let reps = 2 + self.rng.below(3);
            let z0 = self.pos[2];
            self.line(&format!(
                "{retract} {code} X{} Y{} R{} Z{}{extra} L{reps} F{feed}",
                self.num(dx),
                self.num(dy),
                self.num(-clear),
                self.num(-depth),
            ));
            self.pos[0] = self.round(self.pos[0] + reps as f64 * self.round(dx));
            self.pos[1] = self.round(self.pos[1] + reps as f64 * self.round(dy));
            if retract == "G99" {
                self.pos[2] = self.round(z0 - self.round(clear));
            }
        } else {
            self.set_mode(false);
            let z_r = self.round(self.pos[2] - clear);
            let z = self.round(z_r - depth);
            let z0 = self.pos[2];
            for k in 0..2 + self.rng.below(3) {
                let x = {
                    let v = self.rmm(1.0, 5.0);
                    self.round(self.pos[0] + v)
                };
                let y = {
                    let v = self.rmm(-3.0, 3.0);
                    self.round(self.pos[1] + v)
                };
                let line = if k == 0 {
                    format!(
                        "{retract} {code} X{} Y{} R{} Z{}{extra} F{feed}",
                        self.num(x),
                        self.num(y),
                        self.num(z_r),
                        self.num(z),
                    )
                } else {
                    format!("X{} Y{}", self.num(x), self.num(y))
                };
                self.line(&line);
                self.pos[0] = x;
                self.pos[1] = y;
            }
            self.pos[2] = if retract == "G99" { z_r } else { z0 };
        }
        self.line("G80");
        // Back to a known feed for what follows.
        let f = {
            let v = self.rmm(300.0, 2000.0);
            self.num(v)
        };
        self.line(&format!("F{f}"));
    }

    fn event(&mut self) {
        let e = match self.rng.below(6) {
            0 => format!("M3 S{}", 1000 + 500 * self.rng.below(20)),
            1 => "M8".to_string(),
            2 => "M9".to_string(),
            3 => format!("G4 P{}", {
                let v = self.rng.range(0.1, 0.5);
                self.num(v)
            }),
            4 => format!("(note {})", self.rng.below(1000)),
            _ => "M5".to_string(),
        };
        self.line(&e);
    }
}

/// The program of `seed`.
pub fn program(seed: u64) -> String {
    let mut rng = Rng::new(seed);
    let inch = rng.chance(0.3);
    let mut g = Gen {
        rng,
        per_mm: if inch { 1.0 / 25.4 } else { 1.0 },
        decimals: if inch { 5 } else { 4 },
        pos: [0.0; 3],
        incremental: false,
        plane: 0,
        text: String::new(),
    };
    g.line(&format!("(random program {seed})"));
    g.line(if inch {
        "G20 G90 G17 G94"
    } else {
        "G21 G90 G17 G94"
    });
    let f = {
        let v = g.rmm(300.0, 3000.0);
        g.num(v)
    };
    g.line(&format!("F{f}"));
    let start = [g.rmm(-20.0, 20.0), g.rmm(-20.0, 20.0), g.mm(5.0)];
    g.go("G0", start, "");
    let mut z = g.pos;
    z[2] = {
        let v = g.rmm(-1.0, 0.0);
        g.round(v)
    };
    g.go("G1", z, "");
    for _ in 0..3 + g.rng.below(5) {
        match g.rng.below(7) {
            0 | 1 => {
                let inc = g.rng.chance(0.4);
                g.set_mode(inc);
                let p = g.rng.below(3);
                g.set_plane(p);
                g.micro_lines();
            }
            2 | 3 => {
                let inc = g.rng.chance(0.4);
                g.set_mode(inc);
                let p = g.rng.below(3);
                g.set_plane(p);
                g.arcs();
            }
            4 => g.cycle(),
            5 => {
                let mut t = g.pos;
                t[0] += g.rmm(-10.0, 10.0);
                t[1] += g.rmm(-10.0, 10.0);
                g.go("G0", t, "");
            }
            _ => g.event(),
        }
    }
    g.set_mode(false);
    g.set_plane(0);
    g.line("M2");
    g.text
}
