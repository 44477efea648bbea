"""Every deck `peridyn run` runs steps from Python: quasi-static load steps, an adaptive time
step and stages. Stepped in pieces, each gives the command line's files and the arrays of
one call."""

import csv
import pathlib

import numpy as np
import pytest

import peridyn
from conftest import ADAPTIVE, QUASI_STATIC, STAGED

DECKS = {"quasi_static": QUASI_STATIC, "adaptive": ADAPTIVE, "staged": STAGED}

# Lines of summary.txt that hold wall times.
WALL = ("finished ", "timers ", "results in ")


@pytest.fixture(params=list(DECKS))
def deck(request, tmp_path):
    path = tmp_path / f"{request.param}.toml"
    path.write_text(DECKS[request.param])
    return path


def history_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])


def state(sim):
    return (sim.displacement.copy(), sim.velocity.copy(), sim.force.copy(), sim.damage())


def test_stepped_in_pieces_it_gives_the_command_line_s_files(deck, tmp_path, cli):
    out = tmp_path / "cli"
    cli("run", deck, "-o", out, "--quiet")
    sim = peridyn.Simulation(deck, threads=1)
    sim.step(3)
    assert sim.step_count == 3 and not sim.done
    sim.run()
    assert sim.done
    # The history is history.csv's, row for row and bit for bit.
    header, table = history_csv(out / "history.csv")
    history = sim.history()
    assert list(history) == header
    assert table.shape == (len(history["step"]), len(header))
    for k, name in enumerate(header):
        assert np.array_equal(history[name], table[:, k]), name
    # The state is the run's: its last checkpoint and last snapshot, byte for byte.
    sim.save_checkpoint(tmp_path / "end.bin")
    assert (tmp_path / "end.bin").read_bytes() == (out / "checkpoint.bin").read_bytes()
    vtu = pathlib.Path(sim.snapshot(tmp_path / "snap"))
    last = sorted((out / "fields").glob("step_*.vtu"))[-1]
    assert vtu.name == last.name
    assert vtu.read_bytes() == last.read_bytes()


def test_peridyn_run_writes_the_command_line_s_files(deck, tmp_path, cli):
    cli("run", deck, "-o", tmp_path / "cli", "--quiet")
    peridyn.run(deck, tmp_path / "py")
    names = sorted(p.relative_to(tmp_path / "cli") for p in (tmp_path / "cli").rglob("*") if p.is_file())
    assert names == sorted(p.relative_to(tmp_path / "py") for p in (tmp_path / "py").rglob("*") if p.is_file())
    for f in names:
        a, b = (tmp_path / "cli" / f).read_bytes(), (tmp_path / "py" / f).read_bytes()
        if f.name == "summary.txt":
            keep = lambda t: [l for l in t.decode().splitlines() if not l.startswith(WALL)]
            assert keep(a) == keep(b)
        else:
            assert a == b, f


def test_pieces_equal_one_call(deck):
    whole = peridyn.Simulation(deck, threads=2)
    whole.run()
    pieces = peridyn.Simulation(deck, threads=1)
    while not pieces.done:
        pieces.step(2)
    assert pieces.step_count == whole.step_count and pieces.time == whole.time
    for a, b in zip(state(whole), state(pieces)):
        assert np.array_equal(a, b)
    assert whole.energies() == pieces.energies()
    assert pieces.step() == pieces.step_count  # past the end: no step


def test_a_quasi_static_step_is_a_load_step(tmp_path):
    sim = peridyn.Simulation(QUASI_STATIC)
    assert sim.steps == 4 and sim.dt == 0.25
    sim.step()
    assert sim.step_count == 1 and sim.time == 0.25
    # At equilibrium: at rest, the grips where the load step put them.
    top = sim.node_sets["top"]
    assert np.all(sim.velocity == 0)
    assert np.allclose(sim.displacement[top, 1], 2.5e-6, rtol=1e-12)
    history = sim.history()
    assert history["step"].tolist() == [0, 1] and history["iterations"][1] > 0
    sim.run()
    assert sim.time == pytest.approx(1.0) and sim.energies()["broken_bonds"] > 0
    # Split load steps: more committed steps than load steps, each a history row.
    assert sim.step_count > sim.steps
    assert len(sim.history()["step"]) == sim.step_count + 1


def test_an_adaptive_step_moves_the_time_by_its_dt():
    sim = peridyn.Simulation(ADAPTIVE)
    times = []
    while not sim.done:
        sim.step()
        times.append(sim.time)
    dts = np.diff([0.0] + times)
    assert sim.time == pytest.approx(sim.end_time, rel=1e-9)
    # Steps were rejected and retried smaller: the steps are not all of the first dt.
    assert dts.min() < 0.99 * dts.max()
    # The history's rows are at the steps' times, its dt column each recorded step's own.
    history = sim.history()
    steps = history["step"][1:].astype(int)
    assert np.array_equal(history["time"][1:], np.array(times)[steps - 1])
    assert np.allclose(history["dt"][1:], dts[steps - 1], rtol=1e-6, atol=0)


def test_a_staged_run_crosses_its_stages():
    sim = peridyn.Simulation(STAGED)
    assert (sim.stage, sim.stage_name) == (0, "1")
    sim.step(2)  # the two load steps of the preload
    assert sim.time == pytest.approx(1.0)
    assert (sim.stage, sim.stage_name) == (0, "1")
    assert np.all(sim.velocity == 0)  # at rest
    sim.step()
    assert (sim.stage, sim.stage_name) == (1, "release")
    assert sim.time > 1.0
    sim.run()
    assert sim.done and sim.stage == 1
    assert sim.time == pytest.approx(sim.end_time, rel=1e-9)
    stage = sim.history()["stage"]
    assert stage[0] == 1 and stage[-1] == 2


def test_checkpoints_of_every_kind_continue_bitwise(deck, tmp_path):
    whole = peridyn.Simulation(deck)
    whole.run()
    first = peridyn.Simulation(deck)
    first.step(4)  # in a staged run, past the preload
    first.save_checkpoint(tmp_path / "at4.bin")
    second = peridyn.Simulation(deck)
    second.step(1)
    second.load_checkpoint(tmp_path / "at4.bin")
    assert second.step_count == 4 and second.stage == first.stage
    second.run()
    assert second.step_count == whole.step_count
    for a, b in zip(state(whole), state(second)):
        assert np.array_equal(a, b)
