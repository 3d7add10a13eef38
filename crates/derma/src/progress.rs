//! The terminal side of `derma_core::progress`: one indicatif bar showing the current stage of
//! whatever library is running, and notes printed above it (nothing with `--quiet`).

use derma_core::progress::{Note, Progress, Unit};
use indicatif::{ProgressBar, ProgressStyle};

/// Progress bars and notes on stderr. Where stderr is not a terminal (a log, a pipe) the bar is
/// not drawn, so a long stage says once, after [`ESTIMATE_AFTER`], how long it will take.
pub struct Bars {
    bar: Option<ProgressBar>,
    /// The current stage's name and start, and whether its estimate was said.
    stage: std::sync::Mutex<(String, std::time::Instant, bool)>,
}

/// When a long stage's estimate is said (without a terminal to draw the bar on).
const ESTIMATE_AFTER: std::time::Duration = std::time::Duration::from_secs(10);

impl Bars {
    /// Bars that show everything, or nothing when `quiet`.
    pub fn new(quiet: bool) -> Self {
        let bar = (!quiet).then(|| {
            let b = ProgressBar::hidden();
            b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            b
        });
        Self {
            bar,
            stage: std::sync::Mutex::new((String::new(), std::time::Instant::now(), true)),
        }
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

impl Bars {
    /// Says once per stage, after [`ESTIMATE_AFTER`], how long the stage will take in all.
    fn estimate(&self, b: &ProgressBar) {
        let Ok(mut s) = self.stage.lock() else { return };
        let elapsed = s.1.elapsed();
        let (done, total) = (b.position(), b.length().unwrap_or(0));
        if s.2 || elapsed < ESTIMATE_AFTER || done == 0 || total == 0 {
            return;
        }
        s.2 = true;
        let left = elapsed.as_secs_f64() * (total - done.min(total)) as f64 / done as f64;
        eprintln!(
            "{}: {done}/{total} in {:.0} s; about {:.0} s more",
            s.0,
            elapsed.as_secs_f64(),
            left
        );
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
        if let Ok(mut s) = self.stage.lock() {
            *s = (name.to_string(), std::time::Instant::now(), total <= 1);
        }
    }

    fn advance(&self, steps: u64) {
        let Some(b) = &self.bar else { return };
        b.inc(steps);
        if b.is_hidden() {
            self.estimate(b);
        }
    }

    fn note(&self, note: Note) {
        // A warning is said even with --quiet: it tells of a fallback or a doubt in the result.
        match (&self.bar, note.level) {
            (None, derma_core::progress::Level::Warning) => eprintln!("{note}"),
            _ => self.say(note),
        }
    }
}
