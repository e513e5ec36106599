"""The ``initial`` model parameter: lattice (default, unchanged) and disordered starts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fcsweep.analysis.order import global_psi6, psi6
from fcsweep.config import ConfigError, parse_config, run_id_of
from fcsweep.model.disordered import random_centres, soft_disc_pairs, soft_disc_relax, start_rng
from fcsweep.model.lattice import lattice_box
from fcsweep.model.overlap_exact import candidate_pairs, overlap_areas
from fcsweep.model.parameters import ID_OMITS_DEFAULT, PARAMETERS
from fcsweep.model.shape import amplitude_sum, is_admissible
from fcsweep.simulation import Simulation

FIELDS = ("pos", "image", "theta", "a", "b")
BASE = dict(eta=0.03, v0=0.06, Dr=0.01, quadrature="binary")

CONFIG = """
output: out
seed: 5
grid:
  eta: [0.03, 0.1]
  v0: [0.06]
model:
  N: 16
  Dr: 0.1
{extra}
run:
  steps: 200
  sample_every: 20
  checkpoint_every: 100
"""


def mean_overlap(sim) -> float:
    """Exact overlap area per cell (R0^2) of a state."""
    st = sim.state
    i, j, d = candidate_pairs(st.pos, st.a, st.b, box=st.box)
    areas = overlap_areas(d, st.theta[i], st.a[i], st.b[i], st.theta[j], st.a[j], st.b[j], resolution=1024)
    return float(np.sum(areas)) / sim.params.N


@pytest.fixture(scope="module")
def disordered_144():
    return Simulation.create(144, seed=11, initial="disordered", **BASE)


# ------------------------------------------------------------------ the parameter and run ids


def test_initial_is_a_string_parameter_left_out_of_the_id_at_its_default():
    p = PARAMETERS["initial"]
    assert p.type is str and p.default == "lattice" and p.choices == ("lattice", "disordered", "coexistence")
    # (parameters added later, such as adhesion, join the table's omitted-at-default set)
    assert {"integrator": "euler", "initial": "lattice"}.items() <= ID_OMITS_DEFAULT.items()
    base = {"N": 16, "eta": 0.1, "v0": 0.03}
    rid = run_id_of(base, 0)
    assert run_id_of({**base, "initial": "lattice"}, 0) == rid
    assert run_id_of({**base, "integrator": "euler", "initial": "lattice"}, 0) == rid
    assert run_id_of({**base, "initial": "disordered"}, 0) != rid
    assert run_id_of({**base, "integrator": "contact-implicit"}, 0) != rid
    assert run_id_of({**base, "adhesion": 0.0, "adhesion_range": 0.1}, 0) == rid
    assert run_id_of({**base, "adhesion": 0.05}, 0) != rid
    # the id this point had before `initial` existed (run_id_of of commit 60868ad)
    assert rid == "0c61293f8c38"


def test_initial_lattice_and_no_initial_give_the_same_runs_and_trajectory():
    plain = parse_config(CONFIG.format(extra=""))
    explicit = parse_config(CONFIG.format(extra="  initial: lattice"))
    a, b = plain.runs(), explicit.runs()
    assert [(r.run_id, r.seed) for r in a] == [(r.run_id, r.seed) for r in b]
    assert all(r.params["initial"] == "lattice" for r in a + b)
    s1 = Simulation.create(16, **{k: v for k, v in a[0].model_params().items() if k != "initial"})
    s2 = Simulation.create(16, **b[0].model_params())
    s1.advance(300)
    s2.advance(300)
    for k in FIELDS:
        assert np.array_equal(getattr(s1.state, k), getattr(s2.state, k)), k


def test_both_starts_are_a_grid_dimension_with_distinct_ids():
    text = CONFIG.format(extra="").replace("  v0: [0.06]", "  v0: [0.06]\n  initial: [lattice, disordered]")
    cfg = parse_config(text)
    runs = cfg.runs()
    assert cfg.swept == ["eta", "v0", "initial"] and len(runs) == 4
    assert len({r.run_id for r in runs}) == 4 and len({r.seed for r in runs}) == 4
    lattice_ids = {r.run_id for r in parse_config(CONFIG.format(extra="")).runs()}
    assert {r.run_id for r in runs if r.params["initial"] == "lattice"} == lattice_ids


def test_a_wrong_initial_names_the_key_and_the_choices():
    with pytest.raises(ConfigError, match=r"model.initial = 'hex' is not allowed; choose one of "
                                          r"\['lattice', 'disordered', 'coexistence'\]"):
        parse_config(CONFIG.format(extra="  initial: hex"))
    with pytest.raises(ValueError, match=r"^initial = 'hex' is not allowed; choose one of "
                                         r"\['lattice', 'disordered', 'coexistence'\]$"):  # the config's words
        Simulation.create(16, seed=1, eta=0.1, v0=0.0, initial="hex")
    # the explicit constructors record the start they make
    assert Simulation.from_lattice(16, seed=1, eta=0.1, v0=0.0, initial="disordered").params.initial == "lattice"


# ------------------------------------------------------------------ the disordered start


def test_soft_disc_pairs_match_brute_force_and_relaxation_removes_deep_overlaps():
    _, Lx, Ly = lattice_box(144, 0.95)
    box = np.array([Lx, Ly])
    pos = random_centres(144, box, start_rng(3))
    i, j, _ = soft_disc_pairs(pos, box, 2.0)
    d = pos[None] - pos[:, None]
    d -= box * np.rint(d / box)
    r = np.hypot(d[..., 0], d[..., 1])
    assert len(i) == (np.triu(r < 2.0, 1)).sum() and np.all(i < j)
    relaxed, _ = soft_disc_relax(pos, box)
    _, _, d = soft_disc_pairs(relaxed, box, 2.0)
    # random centres overlap up to ~2 R0 deep; relaxed discs at 0.95 (above disc jamming,
    # 0.84) keep overlaps of order 0.1 R0 (measured max 0.35 R0 at N = 256)
    assert np.hypot(*d.T).min() > 1.5


def test_disordered_start_is_relaxed_isotropic_and_admissible(disordered_144):
    sim = disordered_144
    st = sim.state
    for k in FIELDS:
        assert np.all(np.isfinite(getattr(st, k))), k
    assert np.all(is_admissible(st.a, st.b)) and np.all(amplitude_sum(st.a, st.b) < 0.99 * np.sqrt(2 / 3) + 1e-12)
    assert st.step == 0 and st.projections == 0 and not st.image.any()
    assert np.all((st.pos >= 0) & (st.pos < st.box))
    assert np.array_equal(st.box, Simulation.from_lattice(144, seed=11, **BASE).state.box)
    # hexatic order: 1 on the lattice; a disordered packing has |Psi6| ~ N^-1/2 (0.13 at N = 256)
    assert global_psi6(psi6(st.pos, st.box))[0] < 0.5
    # cells deformed where they meet (measured <s> = 0.16 at N = 256) ...
    assert amplitude_sum(st.a, st.b).mean() > 0.05
    # ... and overlap less than the circles of the lattice start (0.039 R0^2 per cell), about
    # as much as a lattice run after 20 time units (N = 256: 1.5e-4 against 5.7e-4)
    lattice = Simulation.from_lattice(144, seed=11, **BASE)
    ours = mean_overlap(sim)
    assert ours < mean_overlap(lattice)
    lattice.advance(4000)
    assert 0.1 < ours / mean_overlap(lattice) < 10.0


def test_disordered_start_is_reproducible_and_leaves_the_noise_stream_alone(disordered_144):
    again = Simulation.create(144, seed=11, initial="disordered", **BASE)
    for k in FIELDS:
        assert np.array_equal(getattr(again.state, k), getattr(disordered_144.state, k)), k
    assert again.params.initial == "disordered"
    lattice = Simulation.from_lattice(144, seed=11, **BASE)
    # the polarities and the dynamics' generator are those of the lattice start
    assert np.array_equal(again.state.theta, lattice.state.theta)
    assert again.rng.bit_generator.state == lattice.rng.bit_generator.state
    # another seed, other centres (a short relaxation suffices to tell)
    other = Simulation.from_disordered(144, seed=12, relax_time=1.0, **BASE)
    assert np.abs(other.state.pos - again.state.pos).max() > 1.0


def test_disordered_checkpoint_names_its_start_and_old_checkpoints_load_as_lattice():
    sim = Simulation.from_disordered(16, seed=2, eta=0.1, v0=0.03, relax_time=1.0)
    sim.advance(50)
    ck = sim.to_checkpoint()
    assert json.loads(ck["params_json"])["initial"] == "disordered"
    back = Simulation.from_checkpoint(ck)
    assert back.params == sim.params
    sim.advance(50)
    back.advance(50)
    assert np.array_equal(back.state.pos, sim.state.pos)
    old = Simulation.from_lattice(16, seed=2, eta=0.1, v0=0.03).to_checkpoint()
    stored = json.loads(old["params_json"])
    del stored["initial"]
    old["params_json"] = json.dumps(stored)
    assert Simulation.from_checkpoint(old).params.initial == "lattice"


# ------------------------------------------------------------------ both starts, end to end

FLUID_POINT = """
output: {out}
seed: 1
grid:
  eta: [0.03]
  v0: [0.06]
  initial: [lattice, disordered]
model:
  N: 256
  Dr: 0.01
  quadrature: binary
run:
  steps: 100000
  sample_every: 500
  checkpoint_every: 50000
"""


@pytest.mark.slow
def test_fluid_point_reads_fluid_from_both_starts(tmp_path):
    """eta = 0.03, v0 = 0.06 (fluid at N = 256-1024, docs/reproduction.md), 500 time units
    from the lattice and from the disordered start, through simulate, analyze, aggregate:
    both fluid, so the label does not depend on the start."""
    import xarray as xr
    from click.testing import CliRunner

    from fcsweep.analysis.phase import PHASE_FLAGS, PHASE_FLUID
    from fcsweep.cli import cli

    path = tmp_path / "fluid.yaml"
    path.write_text(FLUID_POINT.format(out=tmp_path / "out"))
    for command in (["simulate", str(path)], ["analyze", str(path), "--workers", "1"], ["aggregate", str(path)]):
        r = CliRunner().invoke(cli, command)
        assert r.exit_code == 0, r.output
    with xr.open_dataset(tmp_path / "out" / "phase_diagram.nc") as ds:
        assert list(ds["initial"].values) == ["disordered", "lattice"]
        assert ds["initial"].attrs["long_name"] == "initial state of the run"
        phase = ds["phase"].sel(eta=0.03, v0=0.06, N=256, replicate=0)
        labels = {str(k): PHASE_FLAGS[int(v)] for k, v in zip(ds["initial"].values, phase.values)}
    assert labels == {"lattice": PHASE_FLAGS[PHASE_FLUID], "disordered": PHASE_FLAGS[PHASE_FLUID]}, labels
