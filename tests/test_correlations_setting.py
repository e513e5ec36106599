"""``analysis.correlations``: pair counts (the reference), FFT, or ``auto`` (the default:
pairs up to N = 10^4, FFT above) in the per-run analysis.

- The config key: the three values pass, anything else fails naming the key and the
  allowed values.  A run's settings resolve ``auto`` by its N; ``pairs`` at N <= 10^4 is
  left out of the stored settings, so an analysis.h5 written before the key existed (the
  pair counts) is current for ``auto`` and ``pairs`` there and stale for ``fft``; above
  10^4 the method is always written out, so such a file (a pair-count analysis of more
  cells) is stale for ``auto`` and recomputed by FFT.
- ``fcsweep analyze`` of a run above 10^4 cells with the default settings stores
  ``correlations = fft`` and is then current (PAIRS_MAX_N lowered for the test).
- The FFT path of :func:`compute_observables` on a harmonic crystal (eta_G1 = 0.15,
  N = 1024, 10 frames): its frame-mean G6 and C_G1 agree with the pair path's window by window
  within the exchange bound of tests/test_correlation_fft.py (``2 sqrt(2) h / w`` of the
  curve's local range, the fraction of a window's pairs a grid of side ``h`` may move to a
  neighbouring window of width ``w``), G_r within that plus 4 sigma of the two strips'
  counting noise; the exponents agree within their errors (as in
  tests/test_correlation_fft.py) and the KTHNY label is the same, solid (the N >= 4096
  guard lowered to 1024 for the test; measured: eta_G1 0.102 +- 0.030 pairs against
  0.107 +- 0.029 FFT, both solid with P = 1.000).
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from synthetic import harmonic_crystal

from fcsweep.analysis import correlation_fft, kthny
from fcsweep.analysis.run_observables import RunFrames, compute_observables, frame_plan
from fcsweep.config import ConfigError, parse_config
from fcsweep.config.settings import PAIRS_MAX_N, correlation_method, settings_for_run
from fcsweep.io import schema
from fcsweep.io.rundir import analysis_is_current
from fcsweep.results.analyze import DEFAULT_SETTINGS, config_settings, settings_with

CONFIG = """
output: out
grid: {v0: [0.01]}
model: {N: 16, eta: 0.1, density: 0.9, Dr: 0.1, dt: 0.005, modes: 4, contour_points: 24}
run: {steps: 100, sample_every: 10}
"""


@pytest.mark.parametrize("value", ["auto", "pairs", "fft"])
def test_the_values_pass_and_auto_is_left_out(value):
    cfg = parse_config(CONFIG + f"analysis: {{correlations: {value}}}\n")
    assert cfg.analysis.correlations == value
    s = settings_with(config_settings(cfg))
    assert ("correlations" in s) == (value != "auto")
    assert ("correlations" in cfg.to_dict()["analysis"]) == (value != "auto")


def test_a_typo_fails_naming_the_key_and_the_values():
    with pytest.raises(ConfigError, match=r"analysis\.correlations = 'FFT' is not allowed; allowed: auto, pairs, fft"):
        parse_config(CONFIG + "analysis: {correlations: FFT}\n")
    with pytest.raises(ValueError, match="allowed: auto, pairs, fft"):
        settings_with({"correlations": "grid"})


@pytest.mark.parametrize("requested, N, method, stored", [
    ("auto", 1024, "pairs", None), ("auto", PAIRS_MAX_N, "pairs", None), ("auto", PAIRS_MAX_N + 1, "fft", "fft"),
    ("pairs", 1024, "pairs", None), ("pairs", 99856, "pairs", "pairs"),
    ("fft", 1024, "fft", "fft"), ("fft", 99856, "fft", "fft")])
def test_a_run_resolves_the_method_by_its_N(requested, N, method, stored):
    assert correlation_method(requested, N) == method
    s = settings_for_run(settings_with({"correlations": requested}), N)
    assert s.get("correlations") == stored
    # what is stored is read back as the same method
    assert correlation_method(s.get("correlations", "auto"), N) == method
    assert settings_for_run(None, N) is None


def test_the_default_leaves_stored_settings_unchanged(tmp_path):
    """A file with the settings main wrote (DEFAULT_SETTINGS, no key: the pair counts) is
    current for the default and for pairs at N <= 10^4, stale for fft, and stale for the
    default above 10^4 (where the default is FFT)."""
    old = tmp_path / "analysis.h5"
    with h5py.File(old, "w") as f:
        f.attrs[schema.ANALYSIS_SETTINGS_ATTR] = json.dumps(DEFAULT_SETTINGS, sort_keys=True)
        f.attrs[schema.LABEL_RULES_ATTR] = schema.LABEL_RULES
    assert settings_with() == DEFAULT_SETTINGS == settings_with({"correlations": "auto"})
    assert settings_with(config_settings(parse_config(CONFIG))) == DEFAULT_SETTINGS
    for asked in ("auto", "pairs"):
        assert analysis_is_current(old, settings=settings_for_run(settings_with({"correlations": asked}), 4900))
        assert not analysis_is_current(old, settings=settings_for_run(settings_with({"correlations": asked}),
                                                                       PAIRS_MAX_N + 1))
    assert not analysis_is_current(old, settings=settings_for_run(settings_with({"correlations": "fft"}), 4900))


def test_analyze_above_the_bound_stores_fft_and_is_then_current(tmp_path, monkeypatch):
    """The default settings on a run of 16 cells with the bound lowered to 8: the FFT path is
    taken and recorded, a second call and ``fcsweep status`` find the analysis up to date;
    with the bound back at 10^4 the same file is stale (the default there is the pair counts)."""
    from fcsweep.cli.common import status_rows
    from fcsweep.config import settings as settings_module
    from fcsweep.results import analyze
    from fcsweep.sweep.executors import run_sweep

    cfg = parse_config(CONFIG.replace("output: out", f"output: {tmp_path / 'out'}"))
    (spec,) = cfg.runs()
    assert run_sweep(cfg, [spec])[0].outcome == "done"
    traj = cfg.run_dir(spec.run_id) / schema.TRAJECTORY
    monkeypatch.setattr(settings_module, "PAIRS_MAX_N", 8)
    assert analyze.analyze_run(traj, transient=cfg.run.transient)["status"] == "done"
    with h5py.File(traj.with_name(schema.ANALYSIS), "r") as f:
        assert json.loads(f.attrs[schema.ANALYSIS_SETTINGS_ATTR])["correlations"] == "fft"
    assert analyze.analyze_run(traj, transient=cfg.run.transient)["status"] == "skipped"
    assert [r["analysis"] for r in status_rows(cfg)] == ["yes"]
    monkeypatch.setattr(settings_module, "PAIRS_MAX_N", 10000)
    assert [r["analysis"] for r in status_rows(cfg)] == ["stale"]
    assert analyze.analyze_run(traj, transient=cfg.run.transient)["status"] == "done"


def _harmonic_run(n=32, eta=0.15, frames=12, seed=7):
    """A rigid-disc 'run' whose frames are independent harmonic crystals (positions wrapped;
    the unwrapped ones follow frame 0 by minimum image)."""
    confs = harmonic_crystal(n, eta, np.random.default_rng(seed), frames=frames)
    box = np.asarray(confs[0][1], dtype=float)
    pos = np.array([p for p, _ in confs])
    d = pos - pos[:1]
    unwrapped = pos[:1] + d - box * np.round(d / box)
    s = settings_with({"structure_frames": 10, "correlation_frames": 10, "shape_frames": 10}, transient=0.1)
    plan = frame_plan(frames, s)
    run = RunFrames(source="harmonic", params={"R0": 1.0, "v0": 0.02, "Dr": 0.1, "modes": 0}, box=box,
                    time=np.arange(frames) * 5.0, plan=plan, shape_a=None, shape_b=None, rigid=True,
                    positions=pos[plan.structure_frames], unwrapped=unwrapped[plan.frames])
    return run, s


def _windows(r, y, w, lo):
    """Means of a curve over windows of width ``w`` from ``lo`` on, and the range of its bins
    over each window and its two neighbours."""
    s = (r >= lo) & np.isfinite(y)
    k = np.floor(r[s] / w).astype(int)
    n = np.bincount(k)
    has = n > 0
    mean = np.bincount(k, weights=y[s])[has] / n[has]
    rng = np.array([np.ptp(y[s][(k >= j - 1) & (k <= j + 1)]) for j in np.flatnonzero(has)])
    return mean, rng, n[has]


def test_fft_path_gives_the_pair_curves_and_label(monkeypatch):
    monkeypatch.setattr(kthny, "MIN_CELLS", 1024)
    run, s = _harmonic_run()
    sp, cp, _ = compute_observables(run, s)
    sf, cf, _ = compute_observables(run, {**s, "correlations": "fft"})
    box = run.box
    h = correlation_fft.pipeline_spacing(box, s["g6_dr"], s["gr_dx"])
    assert h == pytest.approx(min(s["g6_dr"], s["gr_dx"]) / np.sqrt(2))  # N = 1024: the default grid
    w = 0.5
    frac = 2 * np.sqrt(2) * h / w
    for name in ("G6", "C_G1"):
        (r, p), (rf, f) = cp[name], cf[name]
        assert np.allclose(r, rf)
        pm, rg, _ = _windows(r, p, w, 0.8)
        fm, _, _ = _windows(r, f, w, 0.8)
        assert np.all(np.abs(fm - pm) <= frac * rg + 1e-12), (name, np.max(np.abs(fm - pm) / (frac * rg)))
    (x, p), (xf, f) = cp["Gr"], cf["Gr"]
    assert np.allclose(x, xf)
    pm, rg, nb = _windows(x, p, w, 0.8)
    fm, _, _ = _windows(x, f, w, 0.8)
    N, frames = run.n_cells, 10
    ideal = frames * N * (N - 1) / (box[0] * box[1]) * 2 * s["gr_dx"] * s["gr_dx"]  # pairs per bin at G_r = 1
    sigma = np.sqrt(2 * np.maximum(pm, 1.0 / ideal) / (ideal * nb))
    assert np.all(np.abs(fm - pm) <= frac * rg + 4 * sigma), np.max(np.abs(fm - pm) / (frac * rg + 4 * sigma))
    for k in ("eta_G1", "eta_6", "eta_T"):
        e_p, e_f = sp[f"{k}_err"], sf[f"{k}_err"]
        tol = np.hypot(e_p, e_f) if k == "eta_T" else max(e_p, e_f)  # G_r strips hold partly other pairs
        assert abs(sf[k] - sp[k]) < tol, (k, sp[k], e_p, sf[k], e_f)
    assert sf["kthny"] == sp["kthny"] == kthny.KTHNY_SOLID, (sp["kthny_reason"], sf["kthny_reason"])
    # everything but the correlations is computed alike
    for k in ("psi6", "rho_d", "D_eff", "phase"):
        assert sf[k] == sp[k] or (np.isnan(sf[k]) and np.isnan(sp[k])), k


def test_pipeline_spacing_bounds_the_grid():
    """Default spacing on small boxes; at most MAX_GRID_CELLS cells (+ FFT padding) at any N."""
    box = (60.0, 52.0)
    assert correlation_fft.pipeline_spacing(box, 0.1, 0.2) == pytest.approx(0.1 / np.sqrt(2))
    big = (1950.0, 1690.0)  # about 10^6 cells at spacing 1.95
    h = correlation_fft.pipeline_spacing(big, 0.1, 0.2)
    assert correlation_fft.make_grid(big, h).size <= 1.05 * correlation_fft.MAX_GRID_CELLS
