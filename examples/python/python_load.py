"""A load applied from Python between steps: the quickstart's grips released from the deck's
velocities and driven instead by a displacement that Python computes each step (a ramp held
at 40 µm, then released), with the reaction read from the history.

    python examples/python/python_load.py
"""

import pathlib

import numpy as np

import peridyn

here = pathlib.Path(__file__).resolve().parent
deck = peridyn.load(here.parent / "quickstart.toml").set("solver.end_time", 30e-6)
sim = peridyn.Simulation(deck)
sim.release("top")
sim.release("bottom")

opening = 40e-6  # m, between the grips
ramp = 10e-6  # s
print("time (µs)  opening (µm)  broken bonds")
while not sim.done:
    t = sim.time + sim.dt  # the next step's end
    half = 0.5 * opening * min(t / ramp, 1.0)
    sim.prescribe("top", "displacement", "y", half)
    sim.prescribe("bottom", "displacement", "y", -half)
    sim.step()
    if sim.step_count % 200 == 0:
        print(f"{sim.time * 1e6:9.2f}  {2 * half * 1e6:12.2f}  {sim.energies()['broken_bonds']:12d}")

h = sim.history()
print(f"peak reaction on the top grip: {np.abs(h['reaction_top_y']).max():.4e} N")
