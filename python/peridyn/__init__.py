"""peridyn from Python: the same engine, decks and results as the `peridyn` command, with
numpy arrays in and out.

    import peridyn
    deck = peridyn.load("examples/quickstart.toml")       # validated as `peridyn check` does
    sim = peridyn.Simulation(deck.set("material.fracture_energy", 350.0), threads=2)
    sim.run(until=20e-6)                                 # GIL released, Ctrl-C stops it
    d = sim.damage()                                     # numpy array, one value per node
    peridyn.run(deck, "results/quickstart")              # the files of `peridyn run`

The reference is docs/python.md in the repository.
"""

from ._peridyn import (
    CheckpointError,
    Deck,
    DeckError,
    PeridynError,
    Simulation,
    SimulationError,
    __version__,
    check_deck,
    load,
    run,
    study,
)

__all__ = [
    "CheckpointError",
    "Deck",
    "DeckError",
    "PeridynError",
    "Simulation",
    "SimulationError",
    "__version__",
    "check_deck",
    "load",
    "run",
    "study",
]
