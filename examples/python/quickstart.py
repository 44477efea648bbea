"""The quickstart from Python: examples/quickstart.toml run by the library (the same files
as `peridyn run`), then its crack speed plotted (matplotlib) or printed.

    pip install ./python
    python examples/python/quickstart.py [results-folder]
"""

import csv
import pathlib
import sys

import peridyn

here = pathlib.Path(__file__).resolve().parent
deck = peridyn.load(here.parent / "quickstart.toml")
out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "results/quickstart_python")

report = deck.check()
print(f"{report['nodes']} nodes, {report['bonds']} bonds, {report['steps']} steps of {report['dt']:.3e} s")
summary = peridyn.run(deck, out, quiet=False)
print(summary["text"])

# crack_speed.csv (long format): branch, time, speed, speed over the Rayleigh speed.
with open(out / "crack_speed.csv") as f:
    rows = list(csv.DictReader(f))
branches = {}
for r in rows:
    t, v = branches.setdefault(r["branch"], ([], []))
    t.append(float(r["time"]) * 1e6)
    v.append(float(r["speed_over_rayleigh"]))
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    plt = None
if plt is None:
    print("branch, time (µs), crack speed / Rayleigh speed")
    for name, (t, v) in branches.items():
        for ti, vi in zip(t, v):
            print(f"{name}, {ti:.2f}, {vi:.3f}")
else:
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, (t, v) in branches.items():
        ax.plot(t, v, label=name)
    ax.set_xlabel("time (µs)")
    ax.set_ylabel("crack speed / Rayleigh speed")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "crack_speed_python.png", dpi=120)
    print(f"crack speed plotted in {out / 'crack_speed_python.png'}")
