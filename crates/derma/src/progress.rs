//! The terminal side of `derma_core::progress`: one indicatif bar showing the current stage of
//! whatever library is running, and notes printed above it (nothing with `--quiet`).

use derma_core::progress::{Note, Progress, Unit};
use indicatif::{ProgressBar, ProgressStyle};

/// Progress bars and notes on stderr.
pub struct Bars {
    bar: Option<ProgressBar>,
}

impl Bars {
    /// Bars that show everything, or nothing when `quiet`.
    pub fn new(quiet: bool) -> Self {
        let bar = (!quiet).then(|| {
            let b = ProgressBar::hidden();
            b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            b
        });
        Self { bar }
    }

    /// Clears the bar (before the command's own summary lines).
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }

    /// A line on stderr above the bar (nothing when quiet), for a command's summary.
    pub fn say(&self, text: impl std::fmt::Display) {
        if let Some(b) = &self.bar {
            b.suspend(|| eprintln!("{text}"));
        }
    }
}

impl Progress for Bars {
    fn stage(&self, name: &str, total: u64, unit: Unit) {
        let Some(b) = &self.bar else { return };
        let style = if total > 1 {
            format!(
                "{{spinner}} {{msg}} [{{bar:30}}] {{pos}}/{{len}} {} {{elapsed}} (eta {{eta}})",
                unit.name()
            )
        } else {
            "{spinner} {msg} {elapsed}".to_string()
        };
        b.set_style(
            ProgressStyle::with_template(&style)
                .expect("a valid template")
                .progress_chars("=> "),
        );
        b.set_length(total);
        b.set_position(0);
        b.set_message(name.to_string());
        b.enable_steady_tick(std::time::Duration::from_millis(200));
    }

    fn advance(&self, steps: u64) {
        if let Some(b) = &self.bar {
            b.inc(steps);
        }
    }

    fn note(&self, note: Note) {
        self.say(note);
    }
}
