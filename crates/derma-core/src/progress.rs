//! Progress of long jobs: stages with a unit and a length, steps done, notes for the user, and
//! the wall-clock time of each stage. Libraries report through [`Progress`]; only the CLI draws.
//!
//! A library function that takes a while takes `&dyn Progress` and calls [`Progress::stage`]
//! when a stage begins, [`Progress::advance`] as steps finish (from any thread) and
//! [`Progress::note`] for anything the user should read (a unit guessed, an input converted).
//! [`Job`] wraps the caller's sink, records each stage's duration and every note, and is itself
//! a [`Progress`], so it can be handed to a library further down; [`Prefixed`] labels a
//! sub-job's stages ("detail / patch pass") and [`Folded`] counts a sub-job's steps towards
//! the caller's stage. [`Silent`] ignores everything.

use serde::Serialize;
use std::sync::Mutex;
use std::time::Instant;

/// What a stage counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Unit {
    /// Anything without a more specific unit (a stage of one step).
    Steps,
    /// Texture rows.
    Rows,
    /// Monte Carlo photons.
    Photons,
    /// Table or grid entries.
    Entries,
    /// Patches or neighbourhood windows of a synthesis.
    Windows,
    /// Frames of an animation.
    Frames,
}

impl Unit {
    /// The unit as a plural noun, for display.
    pub fn name(self) -> &'static str {
        match self {
            Unit::Steps => "steps",
            Unit::Rows => "rows",
            Unit::Photons => "photons",
            Unit::Entries => "entries",
            Unit::Windows => "windows",
            Unit::Frames => "frames",
        }
    }
}

/// How much a note matters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// Information about a choice derma made (a unit guessed, a default used).
    Info,
    /// Something in the input that is probably a mistake (and what derma did about it).
    Warning,
}

/// A message for the user. Displayed as its text, with "warning: " before warnings.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Note {
    /// Its importance.
    pub level: Level,
    /// The message itself: what was found, where, and what derma did.
    pub text: String,
}

impl Note {
    /// An informational note.
    pub fn info(text: impl Into<String>) -> Self {
        Self {
            level: Level::Info,
            text: text.into(),
        }
    }

    /// A warning.
    pub fn warning(text: impl Into<String>) -> Self {
        Self {
            level: Level::Warning,
            text: text.into(),
        }
    }
}

impl std::fmt::Display for Note {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.level {
            Level::Info => f.write_str(&self.text),
            Level::Warning => write!(f, "warning: {}", self.text),
        }
    }
}

impl Serialize for Note {
    /// A note serializes as its display text (report files list notes as strings).
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Where a long job reports. Every method has an empty default, so a sink implements only
/// what it shows; all may be called from several threads at once.
pub trait Progress: Sync {
    /// A stage named `name` begins; it has `total` steps of `unit`.
    fn stage(&self, _name: &str, _total: u64, _unit: Unit) {}
    /// `steps` more steps of the current stage are done.
    fn advance(&self, _steps: u64) {}
    /// A message for the user.
    fn note(&self, _note: Note) {}
}

/// Progress that shows nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {}

/// The wall-clock duration of one stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Timing {
    /// The stage's name as given to [`Progress::stage`].
    pub stage: String,
    /// Seconds from its start to the start of the next stage (or the end of the job).
    pub seconds: f64,
}

/// What a [`Job`] recorded.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Log {
    /// Each stage's duration, in order.
    pub timings: Vec<Timing>,
    /// Every note, in the order given.
    pub notes: Vec<Note>,
}

impl Log {
    /// Seconds of the stage named `stage` (summed if it ran more than once).
    pub fn seconds(&self, stage: &str) -> Option<f64> {
        let mut it = self.timings.iter().filter(|t| t.stage == stage).peekable();
        it.peek()?;
        Some(it.map(|t| t.seconds).sum())
    }
}

/// One job's progress: forwards everything to a sink and records stage timings and notes.
pub struct Job<'a> {
    sink: &'a dyn Progress,
    state: Mutex<JobState>,
}

struct JobState {
    current: Option<(String, Instant)>,
    log: Log,
}

impl<'a> Job<'a> {
    /// A job reporting to `sink`.
    pub fn new(sink: &'a dyn Progress) -> Self {
        Self {
            sink,
            state: Mutex::new(JobState {
                current: None,
                log: Log::default(),
            }),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, JobState> {
        // A panic elsewhere cannot leave the log inconsistent: recover it.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Ends the current stage (its time is recorded) without starting another.
    fn end_stage(&self) {
        let mut s = self.state();
        if let Some((name, t0)) = s.current.take() {
            s.log.timings.push(Timing {
                stage: name,
                seconds: t0.elapsed().as_secs_f64(),
            });
        }
    }

    /// Ends the current stage and returns the timings and notes.
    pub fn finish(self) -> Log {
        self.end_stage();
        self.state
            .into_inner()
            .unwrap_or_else(|p| p.into_inner())
            .log
    }
}

impl Progress for Job<'_> {
    fn stage(&self, name: &str, total: u64, unit: Unit) {
        self.end_stage();
        self.state().current = Some((name.to_string(), Instant::now()));
        self.sink.stage(name, total, unit);
    }

    fn advance(&self, steps: u64) {
        self.sink.advance(steps);
    }

    fn note(&self, note: Note) {
        self.state().log.notes.push(note.clone());
        self.sink.note(note);
    }
}

/// Passes a sub-job's steps and notes on but drops its stage announcements, so its steps count
/// towards the caller's own stage (a grid of simulations shown as one bar of all their photons).
pub struct Folded<'a>(pub &'a dyn Progress);

impl Progress for Folded<'_> {
    fn advance(&self, steps: u64) {
        self.0.advance(steps);
    }

    fn note(&self, note: Note) {
        self.0.note(note);
    }
}

/// Passes a sub-job's progress on with its stages labelled `prefix / stage`.
pub struct Prefixed<'a> {
    inner: &'a dyn Progress,
    prefix: &'a str,
}

impl<'a> Prefixed<'a> {
    /// Labels the stages reported through it with `prefix`.
    pub fn new(inner: &'a dyn Progress, prefix: &'a str) -> Self {
        Self { inner, prefix }
    }
}

impl Progress for Prefixed<'_> {
    fn stage(&self, name: &str, total: u64, unit: Unit) {
        self.inner
            .stage(&format!("{} / {name}", self.prefix), total, unit);
    }

    fn advance(&self, steps: u64) {
        self.inner.advance(steps);
    }

    fn note(&self, note: Note) {
        self.inner.note(note);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// A sink that counts what reaches it.
    #[derive(Default)]
    struct Count {
        stages: Mutex<Vec<(String, u64, Unit)>>,
        steps: AtomicU64,
        notes: Mutex<Vec<String>>,
    }

    impl Progress for Count {
        fn stage(&self, name: &str, total: u64, unit: Unit) {
            self.stages
                .lock()
                .unwrap()
                .push((name.to_string(), total, unit));
        }
        fn advance(&self, steps: u64) {
            self.steps.fetch_add(steps, Ordering::Relaxed);
        }
        fn note(&self, note: Note) {
            self.notes.lock().unwrap().push(note.to_string());
        }
    }

    #[test]
    fn job_times_each_stage_and_forwards_everything() {
        let sink = Count::default();
        let job = Job::new(&sink);
        job.stage("a", 10, Unit::Rows);
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| job.advance(2));
            }
        });
        job.note(Note::warning("odd input"));
        job.stage("b", 1, Unit::Steps);
        std::thread::sleep(std::time::Duration::from_millis(20));
        let log = job.finish();
        assert_eq!(sink.steps.load(Ordering::Relaxed), 8);
        assert_eq!(
            *sink.stages.lock().unwrap(),
            vec![("a".into(), 10, Unit::Rows), ("b".into(), 1, Unit::Steps)]
        );
        assert_eq!(*sink.notes.lock().unwrap(), vec!["warning: odd input"]);
        let names: Vec<&str> = log.timings.iter().map(|t| t.stage.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        assert!(log.seconds("b").unwrap() >= 0.02, "{log:?}");
        assert_eq!(log.notes, vec![Note::warning("odd input")]);
    }

    #[test]
    fn prefixed_sub_jobs_are_timed_by_the_outer_job() {
        let sink = Count::default();
        let outer = Job::new(&sink);
        outer.stage("paint", 4, Unit::Rows);
        let sub = Prefixed::new(&outer, "detail");
        sub.stage("patch pass", 3, Unit::Windows);
        sub.note(Note::info("tile 512²"));
        let log = outer.finish();
        let names: Vec<&str> = log.timings.iter().map(|t| t.stage.as_str()).collect();
        assert_eq!(names, ["paint", "detail / patch pass"]);
        assert_eq!(log.notes.len(), 1);
        assert_eq!(
            serde_json::to_string(&log.notes).unwrap(),
            r#"["tile 512²"]"#
        );
    }

    #[test]
    fn folded_sub_jobs_add_steps_to_the_callers_stage() {
        let sink = Count::default();
        sink.stage("grid", 30, Unit::Photons);
        for _ in 0..3 {
            let inner = Folded(&sink);
            inner.stage("entry", 10, Unit::Photons);
            inner.advance(10);
        }
        assert_eq!(sink.stages.lock().unwrap().len(), 1);
        assert_eq!(sink.steps.load(Ordering::Relaxed), 30);
    }
}
