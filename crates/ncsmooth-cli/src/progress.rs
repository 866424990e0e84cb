//! Progress bars on long work ([`indicatif`]), drawn on stderr only when it is a terminal
//! and the run is not `--quiet`: a pipe, a file or CI gets nothing from them.

use crate::Ui;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::Duration;

/// How often a bar is redrawn while the work runs.
const TICK: Duration = Duration::from_millis(120);

/// True when progress is drawn at all.
pub fn visible(ui: Ui) -> bool {
    !ui.quiet && std::io::stderr().is_terminal()
}

/// A bar of `len` steps named `prefix` (hidden unless [`visible`]); its message says what
/// runs now.
pub fn bar(ui: Ui, len: u64, prefix: &str) -> ProgressBar {
    if !visible(ui) {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{prefix} [{bar:25}] {pos}/{len} {elapsed} {wide_msg}")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix(prefix.to_string());
    pb.enable_steady_tick(TICK);
    pb
}

/// A spinner for work of unknown length (hidden unless [`visible`]).
pub fn spinner(ui: Ui, msg: &str) -> ProgressBar {
    if !visible(ui) {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template("{spinner} {elapsed} {wide_msg}") {
        pb.set_style(style);
    }
    pb.set_message(msg.to_string());
    pb.enable_steady_tick(TICK);
    pb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quiet_hides_the_bars() {
        let ui = Ui { quiet: true };
        assert!(bar(ui, 3, "x").is_hidden());
        assert!(spinner(ui, "x").is_hidden());
    }
}
