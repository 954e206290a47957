//! Progress bars on long work: drawn when stderr is a terminal, else a
//! plain line of the bar's state every [`LOG_EVERY`] (so a log of a long
//! run, `2> log` or a batch job's output, shows it is alive and how far
//! it is, without a line per redraw).

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};

/// How often a bar writes its state as a line when stderr is not a
/// terminal (the first line after this long: short work writes none).
pub const LOG_EVERY: Duration = Duration::from_secs(10);

/// A draw target that keeps the last drawn state and writes it as one
/// line to `out` when `every` has passed since the last line (or since it
/// was made), and whenever the bar's step changes (its text other than
/// counts, bar and elapsed time: a report's or an explore's steps each get
/// a line as they start, a long count one every `every`).
struct LogLines {
    /// The line being drawn, when the last line was written, and the step
    /// of the last line drawn.
    state: Mutex<(String, Instant, Option<String>)>,
    every: Duration,
    out: Mutex<Box<dyn Write + Send>>,
}

impl std::fmt::Debug for LogLines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogLines")
            .field("every", &self.every)
            .finish()
    }
}

impl LogLines {
    fn new(every: Duration, out: Box<dyn Write + Send>) -> Self {
        LogLines {
            state: Mutex::new((String::new(), Instant::now(), None)),
            every,
            out: Mutex::new(out),
        }
    }
}

impl TermLike for LogLines {
    fn width(&self) -> u16 {
        100
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.write_str(s)?;
        self.write_str(" | ")
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        if let Ok(mut st) = self.state.lock() {
            st.0.push_str(s);
        }
        Ok(())
    }
    fn clear_line(&self) -> std::io::Result<()> {
        if let Ok(mut st) = self.state.lock() {
            st.0.clear();
        }
        Ok(())
    }
    /// The end of a redraw: the state written as a line when it is due;
    /// a closed or full stderr is ignored (progress is not a result).
    fn flush(&self) -> std::io::Result<()> {
        let Ok(mut st) = self.state.lock() else {
            return Ok(());
        };
        let line = st.0.trim().trim_end_matches('|').trim().to_string();
        st.0.clear();
        if line.is_empty() {
            return Ok(());
        }
        let step = step_of(&line);
        // The first state drawn only sets the step: short work writes none.
        let new_step = st.2.as_ref().is_some_and(|k| *k != step);
        st.2 = Some(step);
        if new_step || st.1.elapsed() >= self.every {
            st.1 = Instant::now();
            if let Ok(mut out) = self.out.lock() {
                let _ = writeln!(out, "{line}");
                let _ = out.flush();
            }
        }
        Ok(())
    }
}

/// Where a bar draws: stderr when it is a terminal, else a line every
/// [`LOG_EVERY`].
/// The step a drawn line shows: its letters outside parentheses (the
/// message and prefix, without counts, bar glyphs or elapsed time).
fn step_of(line: &str) -> String {
    let mut depth = 0usize;
    let mut k = String::new();
    for c in line.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            c if depth == 0 && c.is_alphabetic() => k.push(c),
            _ => {}
        }
    }
    k
}

fn target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::term_like(Box::new(LogLines::new(
            LOG_EVERY,
            Box::new(std::io::stderr()),
        )))
    }
}

/// A bar of `len` steps labelled `what`.
pub fn bar(len: u64, what: &str) -> ProgressBar {
    let b = ProgressBar::with_draw_target(Some(len), target());
    b.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    b.set_prefix(what.to_string());
    b
}

/// A bar of `len` steps labelled `what`, with the rate and the time left.
pub fn bar_eta(len: u64, what: &str) -> ProgressBar {
    let b = ProgressBar::with_draw_target(Some(len), target());
    b.set_style(
        ProgressStyle::with_template(
            "{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed}, about {eta} left)",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    b.set_prefix(what.to_string());
    b
}

/// A spinner for work of unknown length labelled `what`: its message says
/// which step runs, with the time elapsed.
pub fn spinner(what: &str) -> ProgressBar {
    let b = ProgressBar::with_draw_target(None, target());
    b.set_style(
        ProgressStyle::with_template("{prefix} {spinner} {msg} ({elapsed})")
            .expect("valid template"),
    );
    b.set_prefix(what.to_string());
    b.enable_steady_tick(std::time::Duration::from_millis(200));
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A writer into a shared buffer.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);
    impl Write for Shared {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A bar drawn to a log writes its state as one line when due, and
    /// nothing before (short work leaves no line).
    #[test]
    fn a_bar_in_a_log_is_one_line_when_due() {
        let out = Shared::default();
        let log = LogLines::new(Duration::ZERO, Box::new(out.clone()));
        let b =
            ProgressBar::with_draw_target(Some(3), ProgressDrawTarget::term_like(Box::new(log)));
        b.set_style(ProgressStyle::with_template("{prefix} {pos}/{len} {msg}").unwrap());
        b.set_prefix("equiv");
        b.set_message("polar");
        b.inc(1);
        b.finish_and_clear();
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        assert!(text.lines().any(|l| l == "equiv 1/3 polar"), "{text:?}");
        assert!(
            text.lines().all(|l| !l.is_empty() && !l.contains('\r')),
            "{text:?}"
        );
        // Not due for an hour: nothing is written.
        let quiet = Shared::default();
        let log = LogLines::new(Duration::from_secs(3600), Box::new(quiet.clone()));
        let b =
            ProgressBar::with_draw_target(Some(3), ProgressDrawTarget::term_like(Box::new(log)));
        b.inc(2);
        b.finish();
        assert!(quiet.0.lock().unwrap().is_empty());
    }

    /// Not due for an hour, a bar still writes a line when its step
    /// changes, and none while only its count moves.
    #[test]
    fn a_new_step_is_a_line_at_once() {
        let out = Shared::default();
        let log = LogLines::new(Duration::from_secs(3600), Box::new(out.clone()));
        let b =
            ProgressBar::with_draw_target(Some(9), ProgressDrawTarget::term_like(Box::new(log)));
        b.set_style(ProgressStyle::with_template("{prefix} [{bar:9}] {pos}/{len} {msg}").unwrap());
        b.set_prefix("report");
        b.set_message("operation counts");
        b.inc(1);
        b.inc(1);
        b.set_message("render sphere:12");
        b.inc(1);
        b.inc(1);
        b.set_message("render torus:48");
        b.finish_and_clear();
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        // One line per step (the first message is a step too: the bar
        // was drawn with its prefix alone first), none for the counts.
        assert_eq!(lines.len(), 3, "{text:?}");
        assert!(lines[0].ends_with("operation counts"), "{text:?}");
        assert!(lines[1].ends_with("render sphere:12"), "{text:?}");
        assert!(lines[2].ends_with("render torus:48"), "{text:?}");
        assert_eq!(step_of("report [==> ] 5/15 polar (18s)"), "reportpolar");
        assert_eq!(step_of("x (1m 5s, about 3s left) y"), "xy");
    }
}
