"""Shared pieces of the Python tests: small decks that build and run in a second or less,
and the command-line program the files are compared with."""

import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# A 4 mm × 2 mm PMMA strip, Δx = 0.1 mm (800 nodes), a short notch, its grips pulled apart:
# a few hundred steps in well under a second.
PLATE = """\
version = 1
title = "small notched strip"
dimension = 2
plane = "stress"
thickness = 0.5e-3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [0.004, 0.002] }
spacing = 0.1e-3
horizon_ratio = 3.0
partial_volume = "hhb"

[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
fracture_energy = 300.0

[[node_sets]]
name = "top"
region = { type = "rectangle", min = [-1.0, 0.0017], max = [1.0, 1.0] }

[[node_sets]]
name = "bottom"
region = { type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0003] }

[[precracks]]
type = "segment"
start = [-0.001, 0.001]
end = [0.001, 0.001]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = 10.0
time = { type = "ramp", duration = 0.2e-6 }

[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = -10.0
time = { type = "ramp", duration = 0.2e-6 }

[solver]
type = "explicit"
end_time = 4e-6
safety_factor = 0.8

[output]
history_interval = 10
snapshots = 2
png = true
maps = ["damage"]
"""

# The same strip without loads: for deformations written from Python.
FREE = PLATE.split("[[boundary_conditions]]")[0] + """
[solver]
type = "explicit"
end_time = 1e-6
safety_factor = 0.8
"""

# The strip at Δx = 0.2 mm, its grips pulled apart quasi-statically: four load steps of 2.5 µm
# per grip, the last opening the notch into a crack; a load step that breaks more than 10
# bonds is split (16 committed steps in all).
QUASI_STATIC = PLATE.split("[[boundary_conditions]]")[0].replace("spacing = 0.1e-3", "spacing = 0.2e-3") + """
[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "y"
value = 10e-6
time = { type = "ramp", duration = 1.0 }

[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "y"
value = -10e-6
time = { type = "ramp", duration = 1.0 }

[solver]
type = "quasi_static"
load_steps = 4
tolerance = 1e-4
max_broken_bonds = 10

[output]
snapshots = 2
"""

# The strip with seed 004's adaptive time step, strict enough to reject steps.
ADAPTIVE = PLATE.replace("safety_factor = 0.8\n", """safety_factor = 0.8

[solver.adaptive]
max_broken_per_node = 1
stable_steps = 5
""")

# A quasi-static preload with every bond held, then an explicit release (seed 002's
# protocol, examples/seed002_preload_release.toml) on the strip.
STAGED = QUASI_STATIC.replace('no_fail = ["top", "bottom"]', 'no_fail = ["all"]').split("[solver]")[0] + """[solver]
type = "quasi_static"
load_steps = 2
end_time = 1.0
tolerance = 1e-5

[[stages]]
name = "release"
no_fail = ["top", "bottom"]
history_interval = 7
[stages.solver]
type = "explicit"
end_time = 1.5e-6
safety_factor = 0.8

[output]
snapshots = 2
"""
assert "release" in STAGED and "adaptive" in ADAPTIVE


@pytest.fixture
def plate_text():
    return PLATE


@pytest.fixture
def free_text():
    return FREE


@pytest.fixture
def plate_file(tmp_path):
    path = tmp_path / "plate.toml"
    path.write_text(PLATE)
    return path


def cli_binary():
    """The `peridyn` program of this checkout (release build), or $PERIDYN_BIN."""
    given = os.environ.get("PERIDYN_BIN")
    if given:
        return pathlib.Path(given)
    built = ROOT / "target" / "release" / "peridyn"
    if built.exists():
        return built
    found = shutil.which("peridyn")
    if found:
        return pathlib.Path(found)
    pytest.fail("no peridyn program: run `cargo build --release` at the repository root or set PERIDYN_BIN")


@pytest.fixture
def cli():
    binary = cli_binary()

    def run(*args, check=True):
        return subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True, check=check)

    return run
