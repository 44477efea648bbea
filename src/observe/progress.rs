//! Progress on stderr: a bar with ETA on a terminal, plain lines every 10% otherwise.

use super::observer::{Observer, StepView};
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
        Progress {
            bar,
            end_time,
            next_tenth: if quiet { u32::MAX } else { 1 },
            started: Instant::now(),
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

    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()> {
        let step = view.state.step;
        let broken = view.state.broken / 2;
        let done = self.fraction(view.state.time);
        if let Some(bar) = &self.bar {
            bar.set_position((done * BAR_LENGTH as f64) as u64);
            bar.set_message(format!("step {step}, {broken} bonds broken"));
            if view.last {
                bar.finish();
            }
        } else if self.next_tenth <= 10 && (done >= 0.1 * self.next_tenth as f64 || view.last) {
            let elapsed = self.started.elapsed().as_secs_f64();
            let eta = if done > 0.0 {
                elapsed * (1.0 - done) / done
            } else {
                0.0
            };
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
