//! Per-stage timers and counts, printed at the end of every run.

use std::time::Duration;

#[derive(Debug, Clone, Default)]
pub struct Counters {
    /// Grid generation and bond search (building the model from the deck).
    pub grid: Duration,
    pub setup: Duration,
    pub force: Duration,
    pub integrate: Duration,
    pub observe: Duration,
    pub steps: u64,
    pub bonds_broken: u64,
}

impl Counters {
    /// Node-steps per second of the stepping stages (force + integrate).
    pub fn node_steps_per_second(&self, nodes: usize) -> f64 {
        let t = (self.force + self.integrate).as_secs_f64();
        if t > 0.0 {
            self.steps as f64 * nodes as f64 / t
        } else {
            0.0
        }
    }
}
