"""Bad decks and bad arguments raise clear exceptions, never a crash."""

import re

import numpy as np
import pytest

import peridyn

LOCATED = re.compile(r"^.+:\d+:\d+: [\w.\[\]]+: .+$")


def test_a_bad_deck_raises_the_command_line_s_message(tmp_path, plate_text, cli):
    bad = tmp_path / "bad.toml"
    bad.write_text(plate_text.replace("youngs_modulus = 3.09e9", "youngs_modulus = -3.09e9"))
    with pytest.raises(peridyn.DeckError) as e:
        peridyn.load(bad)
    message = str(e.value)
    assert all(LOCATED.match(line) for line in message.splitlines()), message
    assert "material.youngs_modulus" in message
    printed = cli("check", bad, check=False)
    assert printed.returncode != 0
    assert printed.stderr.strip() == f"error: {message}"


def test_unknown_keys_and_syntax_are_located(plate_text):
    with pytest.raises(peridyn.DeckError, match=r"<string>:\d+:\d+: .*youngs_modulu"):
        peridyn.load(plate_text.replace("youngs_modulus", "youngs_modulu"))
    with pytest.raises(peridyn.DeckError, match=r"<string>:\d+:\d+"):
        peridyn.load(plate_text + "\n[material\n")
    with pytest.raises(peridyn.DeckError, match="cannot read the deck"):
        peridyn.load("no/such/deck.toml")


def test_a_dict_deck_is_validated_as_text(plate_text):
    d = peridyn.load(plate_text).to_dict()
    assert peridyn.load(d).check()["nodes"] == 800
    d["material"]["density"] = "heavy"
    with pytest.raises(peridyn.DeckError, match="density"):
        peridyn.load(d)
    d["material"]["density"] = object()
    with pytest.raises(TypeError, match="material.density"):
        peridyn.load(d)
    with pytest.raises(TypeError, match="a deck is"):
        peridyn.load(42)


def test_key_path_edits_are_checked(plate_text):
    deck = peridyn.load(plate_text)
    assert deck.get("material.youngs_modulus") == 3.09e9
    edited = deck.set("material.youngs_modulus", 2.0e9)
    assert edited.get("material.youngs_modulus") == 2.0e9
    assert deck.get("material.youngs_modulus") == 3.09e9
    assert edited.text.count("\n") == deck.text.count("\n")
    assert deck.with_values({"solver.end_time": 1e-6, "boundary_conditions[0].value": 5.0}).get(
        "boundary_conditions[0].value"
    ) == 5.0
    with pytest.raises(peridyn.DeckError, match="no number at `material.colour`"):
        deck.set("material.colour", 1.0)
    with pytest.raises(peridyn.DeckError, match="holds a string"):
        deck.set("material.type", 1.0)
    with pytest.raises(peridyn.DeckError, match="material.density"):
        deck.set("material.density", -1.0)


def test_bad_arguments_raise(plate_text, free_text):
    with pytest.raises(ValueError, match="threads"):
        peridyn.Simulation(plate_text, threads=0)
    with pytest.raises((TypeError, OverflowError)):
        peridyn.Simulation(plate_text, threads=-1)
    sim = peridyn.Simulation(free_text)
    with pytest.raises(KeyError, match="no node set `grip`"):
        sim.prescribe("grip", "velocity", "y", 1.0)
    with pytest.raises(ValueError, match="kind"):
        sim.prescribe("top", "force", "y", 1.0)
    with pytest.raises(ValueError, match="component"):
        sim.prescribe("top", "velocity", "z", 1.0)
    with pytest.raises(ValueError, match="not a number"):
        sim.prescribe("top", "velocity", "y", float("nan"))
    with pytest.raises(ValueError, match="shape"):
        sim.set_displacement(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="does not exist"):
        sim.set_velocity(np.zeros((1, 2)), nodes=[10**6])
    with pytest.raises(ValueError):
        sim.set_velocity(np.full((1, 2), np.inf), nodes=[0])
    with pytest.raises(ValueError, match="until"):
        sim.run(until=float("nan"))
    with pytest.raises((TypeError, OverflowError)):
        sim.step(-1)
    assert sim.step_count == 0  # nothing above changed it
    sim.step()


def test_a_time_step_above_the_stable_one_is_refused(plate_text):
    with pytest.raises(peridyn.DeckError, match="solver.dt.*exceeds the stable time step"):
        peridyn.Simulation(plate_text.replace("safety_factor = 0.8", "dt = 1e-6"))


def test_a_foreign_checkpoint_is_refused_and_changes_nothing(plate_text, tmp_path):
    a = peridyn.Simulation(plate_text)
    a.step(10)
    a.save_checkpoint(tmp_path / "a.bin")
    other = peridyn.Simulation(plate_text.replace("1180.0", "1200.0"))
    with pytest.raises(peridyn.CheckpointError, match="different deck"):
        other.load_checkpoint(tmp_path / "a.bin")
    assert other.step_count == 0
    with pytest.raises(peridyn.CheckpointError, match="no checkpoint"):
        other.load_checkpoint(tmp_path / "missing.bin")
