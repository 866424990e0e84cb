//! The trig method's settings: its corner treatment and thresholds, with their defaults.

use crate::smooth::screen::ScreenOptions;

/// Corner treatment of the trig method.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum CornerStyle {
    /// Inside transition within the tolerance (Fig. 9).
    #[default]
    Round,
    /// Outside loop through the exact corner (Fig. 8), its excursion bounded by
    /// `loop_size_mm`.
    Loop {
        /// Largest distance of the loop from the corner (mm), > 0.
        loop_size_mm: f64,
    },
}

/// Settings of the trig method.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct TrigOptions {
    /// Corner treatment. Default [`CornerStyle::Round`].
    pub corner: CornerStyle,
    /// Micro-line screening. Default [`ScreenOptions::default`].
    pub screen: ScreenOptions,
    /// In loop mode, corners turning by less than this (degrees) are rounded instead.
    /// Default 30: a loop there would turn by more than 330 degrees for a corner the
    /// tolerance band can round.
    pub loop_min_turn_deg: f64,
    /// Corners turning by more than this (degrees) are kept as exact stops (reversals).
    /// Default 179: beyond it both constructions degenerate (`C1` and `C2`, or `B1`, `B2`
    /// and `B`, fall on one line).
    pub stop_turn_deg: f64,
}

/// Builders: each sets one field (see its doc for the default).
impl TrigOptions {
    /// Sets [`TrigOptions::corner`].
    pub fn with_corner(mut self, corner: CornerStyle) -> Self {
        self.corner = corner;
        self
    }

    /// Sets [`TrigOptions::screen`].
    pub fn with_screen(mut self, screen: ScreenOptions) -> Self {
        self.screen = screen;
        self
    }

    /// Sets [`TrigOptions::loop_min_turn_deg`].
    pub fn with_loop_min_turn_deg(mut self, loop_min_turn_deg: f64) -> Self {
        self.loop_min_turn_deg = loop_min_turn_deg;
        self
    }

    /// Sets [`TrigOptions::stop_turn_deg`].
    pub fn with_stop_turn_deg(mut self, stop_turn_deg: f64) -> Self {
        self.stop_turn_deg = stop_turn_deg;
        self
    }
}

impl Default for TrigOptions {
    fn default() -> Self {
        TrigOptions {
            corner: CornerStyle::Round,
            screen: ScreenOptions::default(),
            loop_min_turn_deg: 30.0,
            stop_turn_deg: 179.0,
        }
    }
}
