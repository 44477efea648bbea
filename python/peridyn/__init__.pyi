"""Type stubs of the `peridyn` package (the extension module `peridyn._peridyn`)."""

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

DeckSource = Union["Deck", Dict[str, Any], str, "os.PathLike[str]"]
"""A deck: a `Deck`, a dict, a path, or TOML text (a str holding a newline)."""

Component = Union[str, int]
"""A vector component: "x", "y", "z" or 0, 1, 2."""

NodeSelection = Union[str, Sequence[int], npt.NDArray[np.integer[Any]], None]
"""Nodes: a node set's name, node indices, or None for every node."""

class PeridynError(Exception):
    """Base class of peridyn's errors."""

class DeckError(PeridynError):
    """A deck that cannot be used: one `file:line:column: key: message` line per problem,
    as the command line prints them."""

class SimulationError(PeridynError):
    """A run that cannot continue: unstable, not converging, or an output that cannot be
    written."""

class CheckpointError(PeridynError):
    """A checkpoint that cannot be written or continued (another deck, version, size, or
    corrupt)."""

class Deck:
    """A validated deck: its TOML text and the file it came from. Make one with `load`."""

    @staticmethod
    def from_file(path: Union[str, "os.PathLike[str]"]) -> "Deck":
        """Reads and validates a deck file, as `peridyn check` does."""
    @staticmethod
    def from_toml(text: str, path: Optional[Union[str, "os.PathLike[str]"]] = None) -> "Deck":
        """Validates deck text; `path` names it in messages and anchors relative paths
        (default `<string>`, paths relative to the working directory)."""
    @staticmethod
    def from_dict(data: Dict[str, Any], path: Optional[Union[str, "os.PathLike[str]"]] = None) -> "Deck":
        """Validates a deck given as a dict with the keys of a deck file; messages locate
        problems in the TOML text written from it (`Deck.text`)."""
    @property
    def text(self) -> str:
        """The deck's TOML text."""
    @property
    def file(self) -> str:
        """The deck's file (or `<string>`, `<dict>`)."""
    @property
    def title(self) -> str:
        """The deck's title ("" when it has none)."""
    @property
    def dimension(self) -> int:
        """2 or 3."""
    def get(self, key: str) -> float:
        """The number at a key path (`material.youngs_modulus`, `boundary_conditions[1].value`)."""
    def set(self, key: str, value: float) -> "Deck":
        """A new deck with the number at `key` replaced by `value`, validated again; this
        deck is unchanged (as `peridyn study` edits decks)."""
    def with_values(self, values: Mapping[str, float]) -> "Deck":
        """`set` for several keys at once."""
    def to_dict(self) -> Dict[str, Any]:
        """The deck as a dict (a copy)."""
    def check(self, threads: Optional[int] = None) -> Dict[str, Any]:
        """Builds the model and reports it without stepping (`peridyn check`'s numbers:
        nodes, bonds, bonds_per_node, horizon, spacing, horizon_over_spacing,
        youngs_modulus, poisson_ratio, micromodulus, critical_stretch, p_wave_speed,
        solver, dt, dt_stable, steps, end_time, memory_bytes, bytes_per_bond, materials,
        grid, …, and `text` as printed)."""
    def build(self, threads: Optional[int] = None) -> "Simulation":
        """Builds a simulation of this deck."""

class Simulation:
    """A simulation built from a deck and stepped from Python: any deck `peridyn run` runs,
    one step being one committed step of its run (an explicit step, of the adaptive dt's
    size with `[solver.adaptive]`; a quasi-static load step; a staged deck's steps cross its
    stages as the run's do).

    `positions`, `displacement`, `velocity`, `force`, `volume` and `block` are read-only
    views of the simulation's own arrays (no copy; they follow the simulation as it steps
    and keep it alive). `damage()`, `strain_energy_density()`, `node_sets`, `history()` and
    `energies()` are computed on each call (new arrays)."""

    def __init__(self, deck: DeckSource, threads: Optional[int] = None) -> None:
        """Builds a simulation of `deck` on `threads` worker threads (default: all cores;
        results are identical for any count)."""
    @property
    def report(self) -> Dict[str, Any]:
        """The model as built: `peridyn check`'s numbers (`report["text"]` as printed)."""
    @property
    def dimension(self) -> int:
        """2 or 3."""
    @property
    def nodes(self) -> int:
        """Number of nodes."""
    @property
    def time(self) -> float:
        """Simulation time (s)."""
    @property
    def step_count(self) -> int:
        """Steps taken."""
    @property
    def dt(self) -> float:
        """Time step (s) of the next step: the adaptive controller's next try with
        `[solver.adaptive]`; the load increment (pseudo-time) in a quasi-static stage."""
    @property
    def steps(self) -> int:
        """The deck's number of steps: load steps of a quasi-static deck, the sum of a
        staged deck's stages, an estimate with an adaptive time step (see `done`)."""
    @property
    def end_time(self) -> float:
        """The deck's end time (s; quasi-static: pseudo-time; staged: the stages' sum)."""
    @property
    def done(self) -> bool:
        """Whether the deck's last step is done."""
    @property
    def stage(self) -> int:
        """The stage of the last step: 0 for the deck's own (and in an unstaged deck), k
        for `[[stages]]` k − 1."""
    @property
    def stage_name(self) -> str:
        """The name of the stage of the last step (the deck's, or its number from 1)."""
    def step(self, n: int = 1) -> int:
        """Takes `n` steps, or fewer at the deck's end (the GIL released; Ctrl-C stops
        between steps with KeyboardInterrupt). A quasi-static step is one load step (each
        committed piece of a split one). Returns the step count."""
    def run(self, until: Optional[float] = None) -> int:
        """Steps to the deck's end (its last stage's), or to the first step at or past time
        `until` (s); returns the step count."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Reference positions x (m), (nodes, dimension): a read-only view."""
    @property
    def displacement(self) -> npt.NDArray[np.float64]:
        """Displacement u (m), (nodes, dimension): a read-only view that follows the steps."""
    @property
    def velocity(self) -> npt.NDArray[np.float64]:
        """Velocity v (m/s), (nodes, dimension): a read-only view that follows the steps."""
    @property
    def force(self) -> npt.NDArray[np.float64]:
        """Internal force density (N/m³), (nodes, dimension): a read-only view that follows
        the steps."""
    @property
    def volume(self) -> npt.NDArray[np.float64]:
        """Node volumes (m³; in 2D cell area × thickness), (nodes,): a read-only view."""
    @property
    def block(self) -> npt.NDArray[np.uint32]:
        """Block (material region) of each node, (nodes,): a read-only view."""
    def damage(self) -> npt.NDArray[np.float64]:
        """Damage index per node (0 intact … 1), (nodes,): computed now (a new array)."""
    def strain_energy_density(self) -> npt.NDArray[np.float64]:
        """Strain energy density per node (J/m³), (nodes,): computed now (a new array)."""
    @property
    def node_sets(self) -> Dict[str, npt.NDArray[np.int64]]:
        """Named node sets: name → node indices (copies)."""
    def energies(self) -> Dict[str, float]:
        """kinetic_energy, strain_energy, external_work, damage_dissipation (J) and
        broken_bonds now."""
    def history(self) -> Dict[str, npt.NDArray[np.float64]]:
        """The history so far with the columns of `history.csv` (copies), rows where
        `history.csv` has them (a quasi-static deck: one per load step)."""
    def history_frame(self) -> Any:
        """The history as a pandas DataFrame, one column per `history()` key (needs pandas:
        `ImportError` otherwise)."""
    def prescribe(self, set: str, kind: str, component: Component, value: float) -> None:
        """Prescribes a constant displacement (m) or velocity (m/s) (`kind`) on one
        component of a node set from the next step on, replacing the deck's condition there."""
    def release(self, set: str, component: Optional[Component] = None) -> int:
        """Removes the prescribed conditions of a node set on `component` (default: all);
        returns how many were removed."""
    def set_displacement(self, values: npt.ArrayLike, nodes: NodeSelection = None) -> None:
        """Writes displacements (m), shape (len(nodes), dimension); forces are evaluated again."""
    def set_velocity(self, values: npt.ArrayLike, nodes: NodeSelection = None) -> None:
        """Writes velocities (m/s), shape (len(nodes), dimension)."""
    def snapshot(self, out_dir: Union[str, "os.PathLike[str]"]) -> str:
        """Writes the current fields as `out_dir/fields/step_N.vtu` (series
        `out_dir/fields.pvd`) with the deck's maps; returns the VTU file's path."""
    def save_checkpoint(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes a checkpoint of the current state (`peridyn run`'s format)."""
    def load_checkpoint(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Continues from a checkpoint of this deck (from `save_checkpoint` or `peridyn run`)
        in the stage it was written in, as `peridyn run --restart` does."""

def load(source: DeckSource) -> Deck:
    """Loads and validates a deck from a path, TOML text (a str holding a newline) or a
    dict, as the command line does; a bad deck raises `DeckError`."""

def check_deck(deck: DeckSource, threads: Optional[int] = None) -> Dict[str, Any]:
    """Builds a deck's model and reports it without stepping (`peridyn check`'s numbers)."""

def run(
    deck: DeckSource,
    out_dir: Union[str, "os.PathLike[str]"],
    threads: Optional[int] = None,
    quiet: bool = True,
    restart: bool = False,
) -> Dict[str, Any]:
    """Runs a deck as `peridyn run DECK -o OUT_DIR` does, writing the same files; returns
    the summary (report, wall_seconds, broken_bonds, energies, out_dir, text). Ctrl-C stops
    it after the step in progress with KeyboardInterrupt, its files finished up to that
    step (no summary.txt)."""

def study(
    path: Union[str, "os.PathLike[str]"],
    out_dir: Union[str, "os.PathLike[str]"],
    threads: Optional[int] = None,
    quiet: bool = True,
) -> Dict[str, Any]:
    """Runs (or continues) a parameter study as `peridyn study` does; returns `runs.csv`
    as columns (run, factors, outputs as numpy arrays; status as a list of str)."""
