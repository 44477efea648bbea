"""A parameter sweep as a Python loop: the quickstart's fracture energy varied, each deck
edited by key path (as `peridyn study` edits decks), stepped to 30 µs, and the broken bonds
and crack tip read back as numpy arrays.

    python examples/python/sweep.py
"""

import pathlib

import numpy as np

import peridyn

here = pathlib.Path(__file__).resolve().parent
base = peridyn.load(here.parent / "quickstart.toml")

print("G0 (J/m²)  broken bonds  crack tip x (mm)  time (s)")
for g0 in (200.0, 300.0, 450.0):
    sim = peridyn.Simulation(base.set("material.fracture_energy", g0))
    sim.run(until=30e-6)
    damage = sim.damage()
    cracked = sim.positions[damage > 0.4]
    tip = cracked[:, 0].max() * 1e3 if len(cracked) else float("nan")
    broken = sim.energies()["broken_bonds"]
    print(f"{g0:9.0f}  {broken:12d}  {tip:16.2f}  {sim.time:.3e}")
