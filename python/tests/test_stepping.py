"""Stepping: pieces against one call (bitwise), the history against the command line's,
Ctrl-C between steps, loads driven from Python."""

import _thread
import csv
import signal
import threading

import numpy as np
import pytest

import peridyn


@pytest.fixture
def ctrl_c():
    """Python's own Ctrl-C handler for the test: a process started in the background by a
    shell inherits SIGINT ignored, and Python then leaves it so (interrupt_main does nothing)."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def state(sim):
    return (sim.displacement.copy(), sim.velocity.copy(), sim.force.copy(), sim.damage())


def test_a_run_stepped_in_pieces_equals_one_call(plate_text):
    whole = peridyn.Simulation(plate_text, threads=1)
    whole.run()
    pieces = peridyn.Simulation(plate_text, threads=2)
    for _ in range(7):
        pieces.step()
    pieces.step(33)
    pieces.run(until=0.5 * pieces.end_time)
    pieces.run()
    assert whole.step_count == pieces.step_count == whole.steps
    assert whole.time == pieces.time
    for a, b in zip(state(whole), state(pieces)):
        assert np.array_equal(a, b)
    hw, hp = whole.history(), pieces.history()
    assert list(hw) == list(hp)
    for k in hw:
        assert np.array_equal(hw[k], hp[k]), k
    assert whole.energies() == pieces.energies()


def test_the_history_is_the_command_lines(plate_file, tmp_path, cli):
    out = tmp_path / "cli"
    cli("run", plate_file, "-o", out, "--quiet")
    with open(out / "history.csv") as f:
        rows = list(csv.reader(f))
    sim = peridyn.Simulation(plate_file)
    sim.run()
    history = sim.history()
    assert list(history) == rows[0]
    table = np.array([[float(x) for x in r] for r in rows[1:]])
    assert table.shape == (len(history["time"]), len(history))
    for k, name in enumerate(rows[0]):
        assert np.array_equal(history[name], table[:, k]), name
    assert history["step"][0] == 0 and history["step"][-1] == sim.steps


def test_run_until_a_time_stops_at_the_first_step_past_it(plate_text):
    sim = peridyn.Simulation(plate_text)
    t = 10.5 * sim.dt
    sim.run(until=t)
    assert sim.step_count == 11
    assert sim.time >= t
    sim.run(until=t)  # already there: no step
    assert sim.step_count == 11


def test_ctrl_c_stops_between_steps_and_the_run_goes_on(plate_text, ctrl_c):
    long = plate_text.replace("end_time = 4e-6", "end_time = 4e-3")
    sim = peridyn.Simulation(long, threads=1)
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        sim.run()
    timer.join()
    stopped = sim.step_count
    assert 0 < stopped < sim.steps
    assert sim.time == pytest.approx(stopped * sim.dt, rel=1e-12)
    sim.step(3)
    assert sim.step_count == stopped + 3


def test_a_velocity_prescribed_from_python_moves_the_set(free_text):
    sim = peridyn.Simulation(free_text)
    top = sim.node_sets["top"]
    sim.prescribe("top", "velocity", "y", 2.0)
    sim.step()
    u = sim.displacement
    assert np.allclose(u[top, 1], 2.0 * sim.dt, rtol=1e-12, atol=0)
    assert np.allclose(sim.velocity[top, 1], 2.0, rtol=0, atol=0)
    # Held from step to step until changed; then the new value holds.
    sim.prescribe("top", "velocity", 1, -1.0)
    sim.step(2)
    assert np.allclose(sim.displacement[top, 1], 2.0 * sim.dt - 2.0 * sim.dt, atol=1e-20)
    assert sim.release("top") == 1


def test_a_displacement_prescribed_from_python_is_reached_at_the_next_step(plate_text):
    sim = peridyn.Simulation(plate_text)
    top = sim.node_sets["top"]
    sim.release("top")
    sim.prescribe("top", "displacement", "x", 1e-6)
    sim.step()
    assert np.all(sim.displacement[top, 0] == 1e-6)
    # The reaction of the set follows in the history (columns of every node set).
    assert "reaction_top_x" in sim.history()


def test_ctrl_c_stops_peridyn_run_between_steps_with_its_files_finished(
    plate_text, tmp_path, ctrl_c
):
    long = plate_text.replace("end_time = 4e-6", "end_time = 4e-3")
    out = tmp_path / "out"
    timer = threading.Timer(0.5, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        peridyn.run(long, out, threads=1)
    timer.join()
    # Stopped part-way, every file finished at that step: whole history rows, the snapshot
    # series closed; no summary (the run did not end).
    assert not (out / "summary.txt").exists()
    with open(out / "history.csv") as f:
        rows = list(csv.reader(f))
    assert all(len(r) == len(rows[0]) for r in rows)
    steps = [int(float(r[1])) for r in rows[1:]]
    total = peridyn.check_deck(long)["steps"]
    assert steps == sorted(steps) and 0 < steps[-1] < total
    assert (out / "fields.pvd").read_text().rstrip().endswith("</VTKFile>")
    # Nothing is left running: the next run goes as usual.
    summary = peridyn.run(plate_text, tmp_path / "again")
    assert summary["report"]["steps"] > 0
