"""A quasi-static deck stepped from Python, one load step per `step()`: the tension plate of
examples/quasi_static_tension.toml, coarsened to Δx = 1 mm (10⁴ nodes) and pulled in five
load steps, each relaxed to equilibrium; the top grip's reaction after each one, from the
history, against the elastic estimate E·ε·A.

    python examples/python/quasi_static.py
"""

import pathlib

import peridyn

here = pathlib.Path(__file__).resolve().parent
deck = peridyn.load(here.parent / "quasi_static_tension.toml").with_values(
    {"discretization.spacing": 1e-3, "solver.load_steps": 5}
)
sim = peridyn.Simulation(deck)
E = deck.get("material.youngs_modulus")
side, thickness = 0.1, deck.get("thickness")  # m: the plate is side × side × thickness

print("load step  top grip (µm)  reaction (N)  E·ε·A (N)  ADR iterations")
while not sim.done:
    sim.step()  # one load step: the grips moved, the plate relaxed to equilibrium
    h = sim.history()  # one row per load step, as history.csv has them
    u = h["displacement_top_y"][-1] - h["displacement_bottom_y"][-1]
    elastic = E * u / side * side * thickness
    print(
        f"{sim.step_count:9d}  {h['displacement_top_y'][-1] * 1e6:13.2f}  "
        f"{h['reaction_top_y'][-1]:12.4f}  {elastic:9.4f}  {int(h['iterations'][-1]):14d}"
    )
