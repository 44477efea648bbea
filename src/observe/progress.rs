//! Progress on stderr: a bar with ETA on a terminal, plain lines every 10% otherwise.

use super::observer::{Observer, StepView};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;

pub struct Progress {
    bar: Option<ProgressBar>,
    total: u64,
    next_line: u64,
    started: Instant,
}

impl Progress {
    pub fn new(total: u64, quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let b = ProgressBar::new(total);
            b.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {pos}/{len} steps, ETA {eta} {msg}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            b
        });
        Progress {
            bar,
            total,
            next_line: if quiet { u64::MAX } else { total / 10 },
            started: Instant::now(),
        }
    }
}

impl<const D: usize> Observer<D> for Progress {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.bar.is_some() && step.is_multiple_of(50) || last || step >= self.next_line
    }

    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()> {
        let step = view.state.step;
        let broken = view.state.broken / 2;
        if let Some(bar) = &self.bar {
            bar.set_position(step);
            bar.set_message(format!("{broken} bonds broken"));
            if view.last {
                bar.finish();
            }
        } else if step >= self.next_line && self.next_line != u64::MAX {
            let elapsed = self.started.elapsed().as_secs_f64();
            let eta = if step > 0 {
                elapsed * (self.total - step.min(self.total)) as f64 / step as f64
            } else {
                0.0
            };
            eprintln!("step {step}/{} ({:.0}%), t = {:.4e} s, {broken} bonds broken, elapsed {elapsed:.1} s, ETA {eta:.1} s", self.total, 100.0 * step as f64 / self.total as f64, view.state.time);
            self.next_line = step + (self.total / 10).max(1);
        }
        Ok(())
    }
}
