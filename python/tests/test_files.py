"""Files: `peridyn.run` writes what `peridyn run` writes, byte for byte; snapshots,
checkpoints and studies."""

import pathlib

import numpy as np
import pytest

import peridyn

# Lines of summary.txt that hold wall times (and the folder, which differs by name).
WALL = ("finished ", "timers ", "results in ")


def files(folder):
    return sorted(p.relative_to(folder) for p in pathlib.Path(folder).rglob("*") if p.is_file())


def test_run_writes_the_command_line_s_files(plate_file, tmp_path, cli):
    cli("run", plate_file, "-o", tmp_path / "cli", "--quiet")
    summary = peridyn.run(plate_file, tmp_path / "py")
    assert summary["report"]["nodes"] == 800
    cli_files, py_files = files(tmp_path / "cli"), files(tmp_path / "py")
    assert cli_files == py_files
    assert pathlib.Path("history.csv") in cli_files and pathlib.Path("checkpoint.bin") in cli_files
    for f in cli_files:
        a = (tmp_path / "cli" / f).read_bytes()
        b = (tmp_path / "py" / f).read_bytes()
        if f.name == "summary.txt":
            keep = lambda t: [l for l in t.decode().splitlines() if not l.startswith(WALL)]
            assert keep(a) == keep(b)
        else:
            assert a == b, f


def test_a_deck_from_text_runs_as_its_file(plate_file, plate_text, tmp_path):
    peridyn.run(plate_file, tmp_path / "file")
    peridyn.run(peridyn.Deck.from_toml(plate_text, path=plate_file), tmp_path / "text")
    for name in ("history.csv", "resolved.toml"):
        assert (tmp_path / "file" / name).read_bytes() == (tmp_path / "text" / name).read_bytes()


def test_checkpoints_continue_bitwise(plate_text, tmp_path):
    whole = peridyn.Simulation(plate_text)
    whole.run()
    first = peridyn.Simulation(plate_text)
    first.step(37)
    first.save_checkpoint(tmp_path / "at37.bin")
    second = peridyn.Simulation(plate_text)
    second.load_checkpoint(tmp_path / "at37.bin")
    assert second.step_count == 37 and second.time == first.time
    second.run()
    assert np.array_equal(second.displacement, whole.displacement)
    assert np.array_equal(second.damage(), whole.damage())


def test_the_command_line_s_checkpoint_continues_in_python(plate_file, tmp_path, cli):
    out = tmp_path / "cli"
    cli("run", plate_file, "-o", out, "--quiet")
    sim = peridyn.Simulation(plate_file)
    sim.load_checkpoint(out / "checkpoint.bin")  # written at the last snapshot: the end
    whole = peridyn.Simulation(plate_file)
    whole.run()
    assert sim.step_count == whole.step_count
    assert np.array_equal(sim.displacement, whole.displacement)


def test_restart_continues_a_run(plate_file, tmp_path, cli):
    out = tmp_path / "run"
    cli("run", plate_file, "-o", out, "--quiet", "--stop-after-step", "60", check=False)
    summary = peridyn.run(plate_file, out, restart=True)
    assert summary["report"]["steps"] > 60
    cli("run", plate_file, "-o", tmp_path / "whole", "--quiet")
    assert (out / "history.csv").read_bytes() == (tmp_path / "whole" / "history.csv").read_bytes()


def test_snapshots_on_demand(plate_text, tmp_path):
    sim = peridyn.Simulation(plate_text)
    sim.step(12)
    first = pathlib.Path(sim.snapshot(tmp_path / "snaps"))
    sim.step(3)
    second = pathlib.Path(sim.snapshot(tmp_path / "snaps"))
    assert first.name == "step_00000012.vtu" and first.exists() and second.exists()
    pvd = (tmp_path / "snaps" / "fields.pvd").read_text()
    assert "step_00000012.vtu" in pvd and "step_00000015.vtu" in pvd


def test_a_study_returns_its_table(plate_file, tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(
        f"""version = 1
deck = "{plate_file.name}"
method = "sweep"

[[fixed]]
key = "solver.end_time"
value = 1e-6

[[factors]]
key = "material.youngs_modulus"
values = [2.5e9, 3.5e9]

[[outputs]]
name = "final_strain_energy"
column = "strain_energy"
reduce = "final"
"""
    )
    table = peridyn.study(study, tmp_path / "out")
    assert list(table) == ["run", "material.youngs_modulus", "final_strain_energy", "status"]
    assert np.array_equal(table["material.youngs_modulus"], [2.5e9, 3.5e9])
    assert table["status"] == ["ok", "ok"]
    assert np.all(table["final_strain_energy"] > 0)
    assert (tmp_path / "out" / "runs.csv").exists()


def test_history_frame_needs_pandas(plate_text):
    pandas = pytest.importorskip("pandas")
    sim = peridyn.Simulation(plate_text)
    sim.step(20)
    frame = sim.history_frame()
    assert isinstance(frame, pandas.DataFrame)
    assert list(frame.columns) == list(sim.history())
