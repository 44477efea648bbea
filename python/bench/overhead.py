"""The Python package's overhead on the quickstart (docs/python.md, "Benchmark").

    python python/bench/overhead.py [--repeat N] [--loop-steps K]

1. One call: `peridyn run` (the program) against `peridyn.run` (the same library call from
   Python), alternating, best of N wall times each; and `Simulation.run()` (stepping only)
   against the program's own force + integrate + observe timers.
2. One step per call from a Python loop: `sim.step()` K times against `sim.step(K)`, and
   with `sim.damage()` read after each step: the overhead per call in µs and per node.
3. Memory: the resident size while views are read many times and damage arrays made.
"""

import argparse
import pathlib
import re
import subprocess
import tempfile
import time

import numpy as np

import peridyn

ROOT = pathlib.Path(__file__).resolve().parents[2]
DECK = ROOT / "examples" / "quickstart.toml"
CLI = ROOT / "target" / "release" / "peridyn"


def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 1e6


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--loop-steps", type=int, default=200)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--call-overhead-only", action="store_true",
                    help="only the cost of a call, on the quickstart coarsened to 3200 nodes")
    args = ap.parse_args()
    if args.call_overhead_only:
        return call_overhead(args.repeat)
    threads = [] if args.threads is None else ["--threads", str(args.threads)]
    tmp = pathlib.Path(tempfile.mkdtemp())

    cli, lib, timers = [], [], []
    for k in range(args.repeat):
        t0 = time.perf_counter()
        out = subprocess.run([str(CLI), "run", str(DECK), "-o", str(tmp / "cli"), "--quiet", *threads],
                             capture_output=True, text=True, check=True).stdout
        cli.append(time.perf_counter() - t0)
        m = re.search(r"force ([\d.]+) s, integrate ([\d.]+) s, observe ([\d.]+) s", out)
        timers.append(sum(float(x) for x in m.groups()))
        t0 = time.perf_counter()
        peridyn.run(DECK, tmp / "py", threads=args.threads)
        lib.append(time.perf_counter() - t0)
    print(f"one call, with output: program {min(cli):.3f} s (process), peridyn.run {min(lib):.3f} s "
          f"(in Python): {min(lib) / min(cli):.4f}×  [all: program {cli}, python {lib}]")

    steps = []
    for k in range(args.repeat):
        sim = peridyn.Simulation(DECK, threads=args.threads)
        t0 = time.perf_counter()
        sim.run()
        steps.append(time.perf_counter() - t0)
    print(f"one call, stepping only: Simulation.run() {min(steps):.3f} s against the program's "
          f"force + integrate + observe {min(timers):.3f} s: {min(steps) / min(timers):.4f}×")

    n, nodes = args.loop_steps, sim.nodes
    best = {"step(K)": [], "step() × K": [], "step() + damage() × K": [], "damage() × K": []}
    for k in range(args.repeat):
        a = peridyn.Simulation(DECK, threads=args.threads)
        t0 = time.perf_counter()
        a.step(n)
        best["step(K)"].append(time.perf_counter() - t0)
        b = peridyn.Simulation(DECK, threads=args.threads)
        t0 = time.perf_counter()
        for _ in range(n):
            b.step()
        best["step() × K"].append(time.perf_counter() - t0)
        c = peridyn.Simulation(DECK, threads=args.threads)
        t0 = time.perf_counter()
        for _ in range(n):
            c.step()
            c.damage()
        best["step() + damage() × K"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(n):
            c.damage()
        best["damage() × K"].append(time.perf_counter() - t0)
        assert np.array_equal(a.displacement, b.displacement)
    b = {k: min(v) for k, v in best.items()}
    per_step = b["step(K)"] / n
    call = (b["step() × K"] - b["step(K)"]) / n
    with_damage = (b["step() + damage() × K"] - b["step(K)"]) / n
    print(f"{nodes} nodes, {n} steps: one step {per_step * 1e3:.3f} ms; overhead of a call to step(): "
          f"{call * 1e6:.1f} µs ({call / nodes * 1e9:.2f} ns per node); step() + damage(): "
          f"{with_damage * 1e6:.1f} µs per step over step(K) ({with_damage / nodes * 1e9:.2f} ns per node), "
          f"damage() alone {b['damage() × K'] / n * 1e6:.1f} µs  [{best}]")

    sim = peridyn.Simulation(DECK, threads=args.threads)
    sim.step(10)
    before = rss_mb()
    total = 0.0
    for _ in range(10000):
        total += sim.displacement[0, 0] + sim.velocity[0, 0] + sim.force[0, 0] + sim.positions[0, 0]
    views = rss_mb()
    kept = [sim.displacement for _ in range(1000)]
    held = rss_mb()
    damages = [sim.damage() for _ in range(100)]
    computed = rss_mb()
    print(f"memory: {before:.1f} MB resident after building; {views:.1f} MB after reading 4 × 10⁴ views; "
          f"{held:.1f} MB holding 1000 displacement views (one array is {sim.nodes * 2 * 8 / 1e6:.2f} MB); "
          f"{computed:.1f} MB holding 100 damage arrays ({sim.nodes * 8 / 1e6:.2f} MB each); "
          f"all views share one buffer: {all(np.shares_memory(kept[0], v) for v in kept)}")


def call_overhead(repeat, steps=3000):
    """A call's own cost, where a step is cheap enough for it to show: the quickstart at
    Δx = 0.4 mm (3200 nodes), one thread, `step()` × K against `step(K)`, alternating."""
    deck = peridyn.load(DECK).set("discretization.spacing", 0.4e-3).set("solver.end_time", 1.0)
    one, loop = [], []
    for _ in range(repeat):
        a = peridyn.Simulation(deck, threads=1)
        t0 = time.perf_counter()
        a.step(steps)
        one.append(time.perf_counter() - t0)
        b = peridyn.Simulation(deck, threads=1)
        t0 = time.perf_counter()
        for _ in range(steps):
            b.step()
        loop.append(time.perf_counter() - t0)
        assert np.array_equal(a.displacement, b.displacement)
    per_step = min(one) / steps
    call = (min(loop) - min(one)) / steps
    # The machinery alone: a call that takes no step (release and take back the GIL, lock,
    # look for Ctrl-C, read the step count).
    calls, empty = 100000, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(calls):
            a.step(0)
        empty.append(time.perf_counter() - t0)
    print(f"step(0), the call without a step: {min(empty) / calls * 1e6:.2f} µs (best of {repeat} × {calls})")
    print(f"{a.nodes} nodes, {steps} steps, 1 thread: one step {per_step * 1e6:.1f} µs in step(K); "
          f"a call to step() adds {call * 1e6:.2f} µs  [step(K) {one}, step() × K {loop}]")


if __name__ == "__main__":
    main()
