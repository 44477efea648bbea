//! Predicting a run's memory before it is spent, and refusing what cannot fit.

/// Bytes a node costs besides its bonds: reference data (position, volume, cell size, horizon,
/// block, no-fail), state (u, v, y, force, body force), density, quadrature weights and the
/// observers' per-node fields, plus the model's point state.
pub fn bytes_per_node(dim: usize, point_bytes: usize) -> usize {
    8 * dim * 6 + 8 * 3 + 4 + 1 + 8 + 32 + 16 + point_bytes
}

/// Bytes a node of the whole grid costs while the grid is generated and ordered, before any
/// family: position, cell size, volume, horizon, block and no-fail flag, held twice while the
/// Morton reordering copies them. Every rank of a distributed run generates the whole grid and
/// then keeps its share, so this — not `bytes_per_node` — is what a grid too large to generate
/// is refused on; the whole run's need is checked against the families (one process) or
/// predicted per rank (`peridyn check --ranks`).
pub fn grid_bytes_per_node(dim: usize) -> usize {
    2 * (8 * dim * 2 + 8 * 2 + 4 + 1)
}

/// Bytes a directed bond costs at its peak: while the families are built (neighbour and
/// length held twice, 24 B) or during the run (the stored bytes per bond).
pub fn bytes_per_bond(stored: usize) -> usize {
    stored.max(24)
}

/// Bytes per directed bond that an adaptive dynamic relaxation holds besides the run's state,
/// for a state of `state_bytes` per bond (status and damage history): two more copies (a heap
/// profile finds the fresh state its spectrum is measured on and a copy made in the stage loop).
/// Measured on seed 002's 3D deck: with them the estimate is 1-15 % below the peak resident
/// memory at Δx = 80, 160 and 250 µm, where without them it was 2.1-2.4× low
/// (docs/performance.md, "Memory").
pub fn relaxation_bytes_per_bond(state_bytes: usize) -> usize {
    2 * state_bytes
}

/// The memory this machine can still give (MemAvailable of /proc/meminfo), if known.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    text.lines()
        .find(|l| l.starts_with("MemAvailable:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<u64>().ok())
        .map(|kb| kb * 1024)
}

/// A run's predicted size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub nodes: f64,
    /// Directed bonds.
    pub bonds: f64,
    pub bytes: f64,
}

impl Estimate {
    pub fn new(nodes: f64, bonds: f64, per_node: usize, per_bond: usize) -> Self {
        Estimate {
            nodes,
            bonds,
            bytes: nodes * per_node as f64 + bonds * per_bond as f64,
        }
    }

    /// Refuses an estimate larger than `available` bytes, saying both.
    pub fn fits(&self, available: Option<u64>) -> Result<(), String> {
        let Some(a) = available.filter(|&a| self.bytes > a as f64) else {
            return Ok(());
        };
        let what = if self.bonds == 0.0 {
            format!(
                "generating this grid needs about {:.1} GB ({:.3e} nodes)",
                self.bytes / 1e9,
                self.nodes
            )
        } else {
            format!(
                "this model needs about {:.1} GB ({:.3e} nodes, {:.3e} bonds, {:.0} per node)",
                self.bytes / 1e9,
                self.nodes,
                self.bonds / 2.0,
                self.bonds / self.nodes.max(1.0)
            )
        };
        Err(format!(
            "{what} but the machine has {:.1} GB available; use a larger spacing or a smaller horizon ratio",
            a as f64 / 1e9
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_does_not_fit() {
        let e = Estimate::new(1e6, 1e9, 200, 24);
        assert!(e.fits(Some(10_000_000_000)).is_err());
        assert!(e.fits(Some(100_000_000_000)).is_ok());
        assert!(e.fits(None).is_ok());
        let msg = e.fits(Some(1_000_000_000)).unwrap_err();
        assert!(msg.contains("24.2 GB") && msg.contains("1.0 GB"), "{msg}");
        let grid = Estimate::new(1e8, 0.0, grid_bytes_per_node(3), 0);
        let msg = grid.fits(Some(1_000_000_000)).unwrap_err();
        assert!(
            msg.starts_with("generating this grid needs about 13.8 GB"),
            "{msg}"
        );
    }

    #[test]
    fn reads_available_memory_on_linux() {
        if cfg!(target_os = "linux") {
            assert!(available_bytes().unwrap() > 0);
        }
    }
}
