//! Progress on stderr: a bar with ETA on a terminal, plain lines every 10% otherwise.

use super::observer::{Observer, StageStart, StepView};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;

/// Progress is the fraction of the run's time done (load time in a quasi-static run), not of
/// its steps: adaptive time steps and halved load steps make the step count unknown ahead.
pub struct Progress {
    bar: Option<ProgressBar>,
    end_time: f64,
    /// The next tenth of the run at which a plain line is printed (past 10: never).
    next_tenth: u32,
    started: Instant,
    /// The wall clock and the fraction done when the current stage was first observed: the
    /// ETA follows the current stage's pace (a long quasi-static preload spans little of the
    /// run's time, and the explicit stage after it would otherwise look several times slower).
    /// `None` between a stage's start and its first observed step.
    stage_mark: Option<(Instant, f64)>,
}

/// Positions of the bar: per mille of the run's time.
const BAR_LENGTH: u64 = 1000;

impl Progress {
    pub fn new(end_time: f64, quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let b = ProgressBar::new(BAR_LENGTH);
            b.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {percent}%, ETA {eta} {msg}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            b
        });
        let started = Instant::now();
        Progress {
            bar,
            end_time,
            next_tenth: if quiet { u32::MAX } else { 1 },
            started,
            stage_mark: Some((started, 0.0)),
        }
    }

    fn fraction(&self, time: f64) -> f64 {
        if self.end_time > 0.0 {
            (time / self.end_time).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

impl<const D: usize> Observer<D> for Progress {
    fn wants(&self, step: u64, last: bool) -> bool {
        // Plain lines need the time of every step to catch each tenth; a bar is redrawn every
        // 50 steps.
        self.bar.is_some() && step.is_multiple_of(50) || last || self.next_tenth <= 10
    }

    fn begin_stage(&mut self, _stage: &StageStart) {
        self.stage_mark = None;
        if let Some(bar) = &self.bar {
            bar.reset_eta();
        }
    }

    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()> {
        let step = view.state.step;
        let broken = view.state.broken / 2;
        let done = self.fraction(view.state.time);
        let (mark, done_at_mark) = *self.stage_mark.get_or_insert((Instant::now(), done));
        if let Some(bar) = &self.bar {
            bar.set_position((done * BAR_LENGTH as f64) as u64);
            bar.set_message(format!("step {step}, {broken} bonds broken"));
            if view.last {
                bar.finish();
            }
        } else if self.next_tenth <= 10 && (done >= 0.1 * self.next_tenth as f64 || view.last) {
            let elapsed = self.started.elapsed().as_secs_f64();
            let eta = remaining(mark.elapsed().as_secs_f64(), done_at_mark, done)
                .or_else(|| remaining(elapsed, 0.0, done))
                .unwrap_or(0.0);
            eprintln!(
                "{:.0}% (t = {:.4e} s), step {step}, {broken} bonds broken, elapsed {elapsed:.1} s, ETA {eta:.1} s",
                100.0 * done,
                view.state.time
            );
            while self.next_tenth <= 10 && done >= 0.1 * self.next_tenth as f64 {
                self.next_tenth += 1;
            }
        }
        Ok(())
    }

    /// The step, time and broken bonds only: a distributed run gathers no field for it (its
    /// plain lines want every step).
    fn reads_fields(&self) -> bool {
        false
    }
}

/// Seconds left at the pace of the last `seconds`, over which the fraction done went from
/// `from` to `done`; `None` before any progress.
fn remaining(seconds: f64, from: f64, done: f64) -> Option<f64> {
    (done > from).then(|| seconds * (1.0 - done) / (done - from))
}

#[cfg(test)]
mod tests {
    use super::remaining;

    #[test]
    fn the_eta_follows_the_current_stages_pace() {
        // A preload of 100 s spanning 1 % of the run's time, then 30 s for the next 9 %: the
        // 90 % left take 300 s at the explicit stage's pace, not the 1170 s of the average.
        let close = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() < 1e-9 * b;
        assert!(close(remaining(30.0, 0.01, 0.10), 300.0));
        assert!(close(remaining(130.0, 0.0, 0.10), 1170.0));
        assert_eq!(remaining(5.0, 0.1, 0.1), None);
    }
}
