//! Checkpoints of a run: continuing from one (`--restart`), when the run writes them, and
//! the last good state written after a diagnosed failure.

use super::{RunControl, RunError};
use crate::checkpoint::{Checkpoints, DriverState, Origin, WallClock};
use crate::deck::Deck;
use crate::material::Material;
use crate::observe::{Every, StepView};
use crate::solver::{Fields, Simulation};
use std::path::Path;
use std::time::{Duration, Instant};

/// With `control.restart`, restores the state of the checkpoint in `out` into `sim` and
/// returns its driver state. Called before anything is written: a refused restart leaves the
/// folder as it was.
pub(super) fn restore<const D: usize, M: Material<D>>(
    control: &RunControl,
    out: &Path,
    origin: &Origin,
    sim: &mut Simulation<D, M>,
) -> Result<Option<DriverState<D>>, RunError> {
    if !control.restart {
        return Ok(None);
    }
    let path = out.join(crate::checkpoint::FILE_NAME);
    let driver = crate::checkpoint::restore(&path, origin, &mut sim.state)?;
    sim.impactors.restore(&driver.impactors);
    Ok(Some(driver))
}

/// The checkpoints the deck asks for (at snapshots, `checkpoint`; every `checkpoint_interval`
/// steps) and, with `wall_every`, one at the first step after each stretch of that much wall
/// time, whatever the deck says; or none. A distributed run passes no `wall_every`: its ranks'
/// clocks would not agree on the step.
pub(crate) fn checkpoints(
    deck: &Deck,
    out: &Path,
    origin: Origin,
    snapshot_every: u64,
    wall_every: Option<Duration>,
) -> Option<Checkpoints> {
    let by_deck = deck.output.checkpoint || deck.output.checkpoint_interval.is_some();
    (by_deck || wall_every.is_some()).then(|| Checkpoints {
        path: out.join(crate::checkpoint::FILE_NAME),
        origin,
        snapshots: deck.output.checkpoint.then_some(Every(snapshot_every)),
        interval: deck.output.checkpoint_interval,
        wall: wall_every.map(|every| WallClock {
            every,
            last: Instant::now(),
        }),
    })
}

/// After a diagnosed failure (NaN, energy blow-up, a relaxation that does not converge):
/// writes the latest checkpoint's state, the last good one, as `fields/last_good_step_N.vtu`
/// (not in `fields.pvd`). `None` when there is no checkpoint to read or the file cannot be
/// written: the run's own error is what matters then; and when the checkpoint was written
/// inside a load step, whose state is a relaxation's iterate, not an equilibrium.
pub(super) fn write_last_good<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    (path, origin): &(std::path::PathBuf, Origin),
    out: &std::path::Path,
) -> Option<std::path::PathBuf> {
    let driver = crate::checkpoint::restore(path, origin, &mut sim.state).ok()?;
    if driver.quasi_static.is_some_and(|m| m.in_step.is_some()) {
        return None;
    }
    let fields = out.join("fields");
    std::fs::create_dir_all(&fields).ok()?;
    let file = fields.join(format!("last_good_step_{:08}.vtu", sim.state.step));
    let view = StepView::new(&*sim as &dyn Fields<D>, true);
    crate::observe::snapshots::write_fields(&file, &view).ok()?;
    Some(file)
}
