"""One cost model for bench, dry run and status (:mod:`fcsweep.sweep.cost`).

The estimate is CPU seconds per cell-step, timed at one numba thread on the process CPU
clock (median of repeats) and cached per machine: repeated estimates must agree (the
issue asked for 25 %; with the cache they are identical), ``bench`` and ``simulate
--dry-run`` must quote the same sweep cost from the same measurement, and ``status`` the
same cost per cell-step.
No test asserts a speed: only agreement between estimates and the bookkeeping around them.
"""

from __future__ import annotations

import json
import re
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import load_config
from fcsweep.sweep import bench as bench_module
from fcsweep.sweep import cost
from fcsweep.sweep.interrupt import interrupted_counts, interrupted_phrase
from fcsweep.sweep.status import LEGEND, collect_status, format_status

POINT = dict(N=64, eta=0.05, v0=0.03, Dr=0.1, seed=3, density=0.95, dt=0.005, modes=6, contour_points=40,
             quadrature="binary")
# Hours of CPU (nothing runs it): the estimate prints as "X.Y h", 2 s of start-up are noise.
STEPS = 100_000_000
CONFIG = ("output: out\nseed: 5\ngrid:\n  eta: [0.03, 0.1]\nmodel:\n  N: 64\n  v0: 0.03\n  Dr: 0.1\n"
          f"  quadrature: binary\nrun:\n  steps: {STEPS}\n  sample_every: 100000\n  checkpoint_every: 10000000\n")
_UNIT = {"s": 1.0, "min": 60.0, "h": 3600.0, "d": 86400.0}


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    d = tmp_path / "cost-cache"
    monkeypatch.setenv(cost.CACHE_ENV, str(d))
    return d


def test_second_estimate_comes_from_the_cache_and_is_identical(cache_dir):
    first = cost.cell_step_seconds([POINT])
    assert first.source == "measured" and first.seconds > 0
    files = list(cache_dir.glob("cost-*.json"))
    assert len(files) == 1
    again = cost.cell_step_seconds([POINT])
    assert again.source == "cached" and again.seconds == first.seconds
    # the seed does not change the cost: same entry
    assert cost.cell_step_seconds([{**POINT, "seed": 99}]).seconds == first.seconds
    # another machine (or fcsweep version, or kernel source) does not see the entry
    other = {**cost.machine_fingerprint(), "cpu": "another CPU"}
    real = cost.machine_fingerprint
    try:
        cost.machine_fingerprint = lambda: other
        assert cost.cell_step_seconds([POINT], measure=False).source == "fallback"
    finally:
        cost.machine_fingerprint = real


def test_measurement_without_cache_is_repeatable(monkeypatch):
    """Two measurements (no cache): one thread, process CPU time, median of 5 blocks. The
    issue's bar is 25 % (met on an idle machine); CI's shared 2-core machine has put two
    such measurements 1.47x apart, so 2x here, against the former probe's swing of 18x."""
    monkeypatch.setenv(cost.CACHE_ENV, "off")
    assert cost.cache_file() is None
    a = cost.cell_step_seconds([POINT])
    b = cost.cell_step_seconds([POINT])
    assert a.source == b.source == "measured"
    assert 1 / 2.0 < a.seconds / b.seconds < 2.0


def test_probe_is_the_runs_own_cells_started_disordered_and_capped_in_n():
    p = cost.probe_params(POINT)
    assert p == {**POINT, "initial": "disordered"}
    big = cost.probe_params({**POINT, "N": 1000 * 1000})
    assert big["N"] == cost.PROBE_MAX_N and big["eta"] == POINT["eta"] and big["initial"] == "disordered"
    # a well of given radius shrinks with the probe so that its area fraction is the run's
    from fcsweep.model.confinement import confinement_of_params

    run = {**POINT, "N": 400 * 400, "boundary": "well", "boundary_size": 250.0, "initial": "disordered"}
    probe = cost.probe_params(run)
    well, small = confinement_of_params(run), confinement_of_params(probe)
    assert probe["N"] == cost.PROBE_MAX_N and probe["boundary_size"] == 0.0
    phi = lambda w: w.cell_area / (np.pi * w.size ** 2)  # noqa: E731
    assert phi(well) == pytest.approx(400 * 400 / 250.0 ** 2)
    assert phi(small) == pytest.approx(phi(well), rel=1e-12)


def test_confined_and_sized_runs_are_timed_not_guessed(monkeypatch):
    """The lattice probe could not start a well or a size distribution (both need the
    disordered start) and fell back to the development machine's number."""
    monkeypatch.setenv(cost.CACHE_ENV, "off")
    lines = []
    for extra in ({"boundary": "well", "initial": "disordered"},
                  {"size_distribution": "bidisperse", "initial": "disordered"}):
        c = cost.cell_step_seconds([{**POINT, **extra}], log=lines.append, repeats=1)
        assert c.source == "measured" and c.seconds > 0, lines


def test_fallback_is_the_documented_table(cache_dir):
    c = cost.cell_step_seconds([POINT], measure=False)
    assert c.source == "fallback" and c.seconds == pytest.approx(cost.FALLBACK_US["binary"] * 1e-6)
    jacobi = {**POINT, "quadrature": "arc", "integrator": "contact-jacobi"}
    assert cost.fallback_seconds(jacobi) == pytest.approx(cost.FALLBACK_US["arc"] * 1e-6 * 1.5)
    assert cost.fallback_seconds({**POINT, "modes": 0}) == pytest.approx(cost.FALLBACK_US["disc"] * 1e-6)
    assert not cache_dir.exists()  # nothing measured, nothing written


def _estimate(output: str) -> tuple[float, float]:
    m = re.search(r"estimated (\S+ \w+) of CPU and about (\S+ \w+) of wall", output)
    assert m, output
    return tuple(float(t.split()[0]) * _UNIT[t.split()[1]] for t in m.groups())


def test_dry_runs_agree_with_each_other_and_with_bench(tmp_path, cache_dir, monkeypatch):
    """Bookkeeping, not speed: dry runs and bench go through one measurement, so the timer is
    replaced by a deterministic one (its rate depends on eta, and a "machine" that we slow
    down by 30 % before bench). Two real timings on a shared CI machine differ by up to 1.5x
    (see the repeatability test above); a comparison of two of them here failed CI at 0.68."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.yaml").write_text(CONFIG)
    machine = {"us": 1.0}
    calls = []

    def fake_measure(params, **options):
        calls.append(dict(params))
        return machine["us"] * 1e-6 * (1.0 + params["eta"]), 0.01

    monkeypatch.setattr(cost, "measure_point", fake_measure)

    def sweep_cpu(us):  # the grid: two runs of N = 64 at eta 0.03 and 0.1
        return sum(64 * STEPS * us * 1e-6 * (1.0 + eta) for eta in (0.03, 0.1))

    runs = [CliRunner().invoke(cli, ["simulate", "c.yaml", "--dry-run"]) for _ in range(2)]
    assert all(r.exit_code == 0 for r in runs), runs[0].output
    (cpu1, wall1), (cpu2, wall2) = (_estimate(r.output) for r in runs)
    assert "measured now" in runs[0].output and "measured earlier on this machine" in runs[1].output
    assert sorted(c["eta"] for c in calls) == [0.03, 0.1]  # the second dry run timed nothing
    assert cpu1 == cpu2 and wall1 == wall2
    assert cpu1 == pytest.approx(sweep_cpu(1.0), abs=0.05 * 3600)  # printed to 0.1 h
    machine["us"] = 1.3
    r = CliRunner().invoke(cli, ["bench", "c.yaml", "--json"])
    assert r.exit_code == 0, r.output
    bench = json.loads(r.output[r.output.index("{"):])
    # bench times afresh with the same protocol (same points) and quotes the sweep with it
    assert calls[2:] == calls[:2]
    # (plus each run's bookkeeping: 10 checkpoints and the run's own files)
    books = 2 * (bench_module.RUN_CPU_S + 10 * bench_module.CHECKPOINT_CPU_S)
    assert bench["sweep_cpu_seconds"] == pytest.approx(sweep_cpu(1.3) + books, rel=1e-6)
    # and refreshes the cache: the next dry run quotes bench's number without timing again
    after, _ = _estimate(CliRunner().invoke(cli, ["simulate", "c.yaml", "--dry-run"]).output)
    assert len(calls) == 4
    assert after == pytest.approx(bench["sweep_cpu_seconds"], abs=0.05 * 3600 + 2.0)
    assert not (tmp_path / "out").exists()


def test_status_reports_the_cpu_left_with_the_same_cost(tmp_path, cache_dir, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.yaml").write_text(CONFIG)
    cfg = load_config(tmp_path / "c.yaml")
    rows = collect_status(cfg)  # nothing cached: the documented fallback, never a timing
    per_run = 64 * STEPS * cost.FALLBACK_US["binary"] * 1e-6
    assert [r["cpu_left"] for r in rows] == pytest.approx([per_run] * 2, rel=1e-3)
    assert "fcsweep bench" in format_status(rows).splitlines()[-2]
    points = cost.setting_points(cfg.runs())
    c = cost.cell_step_seconds(points)  # measured and cached, as a dry run or bench would
    rows = collect_status(cfg)
    assert sum(r["cpu_left"] for r in rows) == pytest.approx(2 * 64 * STEPS * c.seconds, rel=1e-3)
    text = format_status(rows)
    assert "left: about" in text and "measured earlier on this machine" in text
    assert LEGEND in text and "projected" in text.splitlines()[0]


def test_interrupt_counts_cannot_contradict():
    """The summary line and the stop line quote one phrase: runs stopped mid-run (each
    checkpointed) and runs not started because the stop came first."""
    o = [SimpleNamespace(outcome="interrupted", message="stopped at step 300 (SIGINT)"),
         SimpleNamespace(outcome="interrupted", message="not started"),
         SimpleNamespace(outcome="done", message="")]
    assert interrupted_counts(o) == (1, 1)
    assert interrupted_phrase(o) == "1 stopped and checkpointed, 1 not started"
    assert interrupted_phrase(o[2:]) == ""


def test_numpy_twin_warns_that_it_is_slow_above_256_cells():
    from fcsweep.model import rates

    def call(N):
        z = np.zeros((N, 5))
        with pytest.raises(ValueError):  # a bad rule: stops right after the size check
            rates(np.zeros((N, 2)), np.zeros(N), z, z, eta=0.03, v0=0.06, quadrature="none")

    with pytest.warns(UserWarning, match="slow numpy reference"):
        call(257)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        call(256)
