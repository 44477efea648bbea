"""Node data: shapes, units and values after known deformations, views and copies as
documented."""

import gc

import numpy as np
import pytest

import peridyn


def test_shapes_and_reference_data(plate_text):
    sim = peridyn.Simulation(plate_text)
    n = sim.nodes
    assert n == sim.report["nodes"] == 800
    for name in ("positions", "displacement", "velocity", "force"):
        a = getattr(sim, name)
        assert a.shape == (n, 2) and a.dtype == np.float64, name
    assert sim.volume.shape == (n,) and sim.block.shape == (n,)
    assert sim.block.dtype == np.uint32
    assert sim.damage().shape == (n,) and sim.strain_energy_density().shape == (n,)
    x = sim.positions
    assert x.min(axis=0) == pytest.approx([0.05e-3, 0.05e-3])
    assert x.max(axis=0) == pytest.approx([3.95e-3, 1.95e-3])
    # Volume: cell area × thickness (m³), the whole strip's.
    assert sim.volume.sum() == pytest.approx(4e-3 * 2e-3 * 0.5e-3, rel=1e-12)
    sets = sim.node_sets
    assert set(sets) == {"top", "bottom"}
    assert np.all(x[sets["top"], 1] > 1.7e-3) and np.all(x[sets["bottom"], 1] < 0.3e-3)
    assert sets["top"].dtype == np.int64


def test_a_uniform_stretch_gives_u_equal_to_strain_times_x(free_text):
    sim = peridyn.Simulation(free_text)
    eps = 1e-4
    x = sim.positions
    sim.set_displacement(eps * x)
    assert np.array_equal(sim.displacement, eps * x)
    # Away from the edges (3 horizons) the family is whole: no net force, and the energy
    # density of an equibiaxial strain, E ε² / (1 − ν) with ν = 1/3 (PMB in plane stress).
    r = sim.report
    inner = (x[:, 0] > 1.0e-3) & (x[:, 0] < 3.0e-3) & (x[:, 1] > 0.4e-3) & (x[:, 1] < 1.6e-3)
    interior_far = inner & (np.abs(x[:, 1] - 1e-3) > 0.35e-3)  # off the notch's bonds
    assert interior_far.sum() > 20
    f = sim.force
    boundary = np.abs(f[~inner]).max()
    assert np.abs(f[interior_far]).max() < 1e-9 * boundary
    w = sim.strain_energy_density()
    expected = r["youngs_modulus"] * eps**2 / (1.0 - r["poisson_ratio"])
    assert w[interior_far] == pytest.approx(expected, rel=0.03)
    # Velocities written the same way, and one step moves every free node by v·dt.
    v = np.zeros_like(x)
    v[:, 0] = 3.0
    sim.set_displacement(np.zeros_like(x))
    sim.set_velocity(v)
    assert np.array_equal(sim.velocity, v)
    sim.step()
    assert sim.displacement[:, 0] == pytest.approx(3.0 * sim.dt, rel=1e-6)


def test_views_are_read_only_and_follow_the_simulation(plate_text):
    sim = peridyn.Simulation(plate_text)
    u = sim.displacement
    for a in (sim.positions, u, sim.velocity, sim.force, sim.volume, sim.block):
        assert not a.flags.writeable and not a.flags.owndata
        with pytest.raises(ValueError):
            a[0] = 1.0
    before = u.copy()
    sim.step(20)
    assert not np.array_equal(u, before)  # the same view, now at step 20
    assert np.array_equal(u, sim.displacement)
    assert np.shares_memory(u, sim.displacement)


def test_computed_arrays_are_new_copies(plate_text):
    sim = peridyn.Simulation(plate_text)
    sim.step(50)
    d1, d2 = sim.damage(), sim.damage()
    assert d1.flags.writeable  # its own buffer (handed over by the library, not copied again)
    assert not np.shares_memory(d1, d2)
    d1[:] = 7.0  # a copy: the simulation does not see it
    assert np.array_equal(sim.damage(), d2)
    h = sim.history()
    h["time"][:] = 0.0
    assert sim.history()["time"][-1] > 0.0


def test_a_view_keeps_the_simulation_alive(plate_text):
    sim = peridyn.Simulation(plate_text)
    sim.step(5)
    u = sim.displacement
    expected = u.copy()
    del sim
    gc.collect()
    assert np.array_equal(u, expected)
    assert u.base is not None


def test_the_report_has_check_s_numbers(plate_text, free_text):
    sim = peridyn.Simulation(plate_text)
    r = sim.report
    assert r["nodes"] == 800 and r["dimension"] == 2 and r["model"] == "pmb"
    assert r["horizon_over_spacing"] == pytest.approx(3.0)
    assert r["dt"] == pytest.approx(0.8 * r["dt_stable"])
    assert r["steps"] == sim.steps == int(np.ceil(4e-6 / r["dt"]))
    assert r["memory_bytes"] > 0 and r["bonds"] > 0
    assert "nodes            800" in r["text"]
    assert peridyn.load(plate_text).check(threads=1)["bonds"] == r["bonds"]
