//! How a controller runs a `G2`/`G3`: exactly (LinuxCNC's planner follows the circle), or
//! as chords the firmware cuts it into, which lie inside the arc by up to their sagitta.
//! A writer that writes an arc for such a controller counts that sagitta in its budget
//! ([`ArcChords::sagitta_mm`]): the executed path, not the arc, must stay within the
//! tolerance.
//!
//! The firmwares' own defaults, as they segment an arc of radius `r` sweeping `a`:
//!
//! * grbl 1.1 and grblHAL (`mc_arc`): `floor(r a / c)` equal chords, `c` the chord whose
//!   sagitta is `$12`, the arc tolerance (default 0.002 mm); none (one straight move)
//!   when the arc is shorter than `c`. A chord spans at least `c`, up to `2 c` when there
//!   is one: its sagitta is up to four times `$12`.
//! * Marlin 2.0.9.2 (`plan_arc`): segments of at most `MAX_ARC_SEGMENT_MM` (1 mm), at
//!   least `MIN_CIRCLE_SEGMENTS` (72) per turn, and no shorter than
//!   `MIN_ARC_SEGMENT_MM` (0.1 mm) unless the arc is. Later versions round the count
//!   otherwise, so that on radii of a few mm a chord may reach twice the shortest
//!   segment (not counted: up to about 0.004 mm more at a 1 mm radius).
//! * Klipper (`[gcode_arcs] resolution`, 1 mm): `floor(r a / resolution)` equal chords,
//!   at least one, so a short arc may be one chord of up to twice the resolution.
//!
//! A firmware built or configured otherwise (a longer `MAX_ARC_SEGMENT_MM`, a coarser
//! Klipper resolution, a larger `$12`) cuts longer chords than these: its setting is given
//! with [`ArcChords::with_segment_mm`] (`smooth --arc-segment`). Marlin before 2.0.9.2
//! (`MM_PER_ARC_SEGMENT`, 24 segments per turn) is not modelled.

use std::f64::consts::TAU;

/// A controller's way of running an arc.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum ArcChords {
    /// The controller runs the circle itself.
    #[default]
    Exact,
    /// Chords within `mm` of the arc (grbl's `$12`).
    Tolerance {
        /// Largest sagitta (mm).
        mm: f64,
    },
    /// Segments of at most `max_mm`, at least `per_turn` per turn, at least `min_mm` long
    /// (Marlin).
    Segments {
        /// Longest segment (mm).
        max_mm: f64,
        /// Shortest segment (mm), unless the arc is shorter.
        min_mm: f64,
        /// Fewest segments per full turn.
        per_turn: f64,
    },
    /// `floor(length / resolution_mm)` equal chords, at least one (Klipper).
    Floor {
        /// The resolution (mm).
        resolution_mm: f64,
    },
}

impl ArcChords {
    /// The same rule with the firmware's one length setting at `mm`: grbl's `$12` (the
    /// arc tolerance), Marlin's `MAX_ARC_SEGMENT_MM` (the longest segment; its
    /// `MIN_ARC_SEGMENT_MM` stays 0.1 mm, which Marlin's clamp prefers when the longest is
    /// set below it), Klipper's `[gcode_arcs] resolution`. `None` for a controller that
    /// runs the circle ([`ArcChords::Exact`]).
    pub fn with_segment_mm(self, mm: f64) -> Option<ArcChords> {
        Some(match self {
            ArcChords::Exact => return None,
            ArcChords::Tolerance { .. } => ArcChords::Tolerance { mm },
            ArcChords::Segments {
                min_mm, per_turn, ..
            } => ArcChords::Segments {
                max_mm: mm,
                min_mm,
                per_turn,
            },
            ArcChords::Floor { .. } => ArcChords::Floor { resolution_mm: mm },
        })
    }

    /// The most the controller's chords lie inside an arc of radius `r_mm` sweeping
    /// `sweep_rad` (0 for [`ArcChords::Exact`]).
    pub fn sagitta_mm(self, r_mm: f64, sweep_rad: f64) -> f64 {
        let angle = match self {
            ArcChords::Exact => return 0.0,
            ArcChords::Tolerance { mm } => {
                // Half the chord of sagitta `mm`; `mc_arc` cuts `floor(half length / it)`.
                let half_chord = (mm * (2.0 * r_mm - mm)).max(0.0).sqrt();
                let n = if half_chord > 0.0 {
                    (0.5 * r_mm * sweep_rad / half_chord).floor()
                } else {
                    0.0
                };
                if n >= 1.0 {
                    sweep_rad / n
                } else {
                    sweep_rad
                }
            }
            ArcChords::Segments {
                max_mm,
                min_mm,
                per_turn,
            } => {
                let by_length = (max_mm / r_mm).min(TAU / per_turn);
                by_length.max(min_mm / r_mm).min(sweep_rad)
            }
            ArcChords::Floor { resolution_mm } => {
                let n = (r_mm * sweep_rad / resolution_mm).floor().max(1.0);
                sweep_rad / n
            }
        };
        r_mm * (1.0 - (0.5 * angle.min(TAU)).cos())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_firmwares_chords() {
        let marlin = ArcChords::Segments {
            max_mm: 1.0,
            min_mm: 0.1,
            per_turn: 72.0,
        };
        // A large arc: 1 mm chords, sagitta 1 / (8 r).
        assert!((marlin.sagitta_mm(100.0, 1.0) - 1.0 / 800.0).abs() < 1e-6);
        // A small one: 5 degree chords.
        let s = marlin.sagitta_mm(5.0, 3.0);
        assert!((s - 5.0 * (1.0 - (TAU / 144.0).cos())).abs() < 1e-12);
        // Klipper: one chord for an arc shorter than twice the resolution.
        let klipper = ArcChords::Floor { resolution_mm: 1.0 };
        let s = klipper.sagitta_mm(1.0, 1.9);
        assert!((s - (1.0 - (0.95f64).cos())).abs() < 1e-12);
        assert_eq!(ArcChords::Exact.sagitta_mm(1.0, 1.0), 0.0);
        // grbl: floor(length / c) chords, c the chord of sagitta $12. An arc of 1.9 c is
        // one chord, sagitta about 3.6 $12; one of 20 c has 20, sagitta $12.
        let grbl = ArcChords::Tolerance { mm: 0.002 };
        let r = 10.0;
        let c = 2.0 * (0.002 * (2.0 * r - 0.002f64)).sqrt();
        let s = grbl.sagitta_mm(r, 1.9 * c / r);
        assert!((s - r * (1.0 - (0.95 * c / r).cos())).abs() < 1e-12 && s > 0.0035);
        let s = grbl.sagitta_mm(r, 20.0 * c / r);
        assert!((s - 0.002).abs() < 1e-6, "{s}");
        // Shorter than one chord: one straight move, within $12.
        assert!(grbl.sagitta_mm(r, 0.9 * c / r) < 0.002);
    }

    #[test]
    fn a_firmware_setting_lengthens_the_chords() {
        let marlin = ArcChords::Segments {
            max_mm: 1.0,
            min_mm: 0.1,
            per_turn: 72.0,
        };
        // 2 mm segments on a large arc: four times the sagitta of 1 mm ones.
        let long = marlin.with_segment_mm(2.0).unwrap();
        let ratio = long.sagitta_mm(100.0, 1.0) / marlin.sagitta_mm(100.0, 1.0);
        assert!((ratio - 4.0).abs() < 1e-3, "{ratio}");
        // Below Marlin's shortest: its clamp takes the shortest, 0.1 mm chords.
        let fine = marlin.with_segment_mm(0.05).unwrap();
        let at_min = 100.0 * (1.0 - (0.5 * 0.1 / 100.0f64).cos());
        assert!((fine.sagitta_mm(100.0, 1.0) - at_min).abs() < 1e-12);
        let klipper = ArcChords::Floor { resolution_mm: 1.0 };
        let coarse = klipper.with_segment_mm(3.0).unwrap();
        assert!(coarse.sagitta_mm(10.0, 0.5) > klipper.sagitta_mm(10.0, 0.5));
        assert_eq!(
            ArcChords::Tolerance { mm: 0.002 }.with_segment_mm(0.01),
            Some(ArcChords::Tolerance { mm: 0.01 })
        );
        assert_eq!(ArcChords::Exact.with_segment_mm(1.0), None);
    }
}
