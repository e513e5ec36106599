"""One phase rule for a run and for a grid point; both starts at a grid point (issue 32).

The aggregate labels a point by the same function as a run (:func:`phase_label` on
:func:`phase_evidence`), fed with the replicate-combined scalars of
:func:`fcsweep.analysis.points.combine_runs`; with one replicate those are the run's own,
so the labels and confidences must be identical, whatever the evidence.
"""

import numpy as np
import pytest
import xarray as xr

from fcsweep.results.reduce import POINT_INPUTS, add_point_labels
from fcsweep.analysis.cage import broken_probability
from fcsweep.analysis.phase import (PHASE_FLUID, PHASE_SOLID, PHASE_UNDETERMINED, classify_percolation,
                                    phase_evidence, phase_label)
from fcsweep.analysis.points import (HYSTERESIS_AGREE, HYSTERESIS_DISAGREE, HYSTERESIS_ONE_SIDED, agree,
                                     point_labels)


def _evidence(rng) -> dict:
    """A run's stored scalars drawn over every branch of the rule (NaNs included)."""
    ratio = rng.choice([0.02, 0.9, 1.02, 1.5, 4.0, np.nan])
    err = rng.choice([0.01, 0.05, 0.3, np.nan])
    pick = lambda *v: float(rng.choice(v))  # noqa: E731
    sc = {"cage_msd_ratio": ratio, "cage_msd_ratio_err": err, "cage_lag": 500.0,
          "cage_broken_probability": broken_probability(ratio, err) if np.isfinite(ratio) else np.nan,
          "D_eff_cr_late": pick(5e-4, 1.1e-3, 2e-3, 0.05, np.nan), "D_eff_cr_late_err": pick(1e-4, 5e-4, np.nan),
          "D_eff_cr": pick(1e-5, 9e-4, 3e-3, np.nan), "D_eff_cr_err": pick(1e-5, 3e-4, np.nan),
          "D_eff_long": pick(2e-4, 4e-3), "D_eff_long_err": pick(1e-4, 1e-3),
          "D_eff": pick(5e-4, 2e-3, np.nan), "D_eff_err": pick(1e-4, 1e-3),
          "msd_long_enough": pick(0.0, 1.0), "msd_diffusive": pick(0.0, 1.0), "n_time_blocks": pick(1.0, 4.0),
          "q_mean": pick(3.6, 3.81, 3.95, np.nan), "q_mean_err": pick(0.002, 0.05, np.nan),
          "rho_d": pick(0.2, 0.49, 0.7, np.nan), "rho_d_err": pick(0.01, 0.05, np.nan)}
    return sc


def _same(a, b) -> bool:
    return a.code == b.code and (np.isnan(a.confidence) and np.isnan(b.confidence)
                                 or a.confidence == pytest.approx(b.confidence, rel=1e-12, abs=1e-15))


@pytest.mark.parametrize("conf, threshold", [(0.95, 0.5), (0.8, 0.45)])
def test_a_point_with_one_replicate_carries_its_runs_labels(conf, threshold):
    rng = np.random.default_rng(32)
    codes = set()
    for _ in range(600):
        sc = _evidence(rng)
        run = phase_label(phase_evidence(sc), min_confidence=conf)
        perc = classify_percolation(sc["rho_d"], sc["rho_d_err"], min_confidence=conf, threshold=threshold)
        point, ppoint = point_labels([sc], min_confidence=conf, percolation_threshold=threshold)
        assert _same(run, point), (sc, run, point)
        assert _same(perc, ppoint), (sc, perc, ppoint)
        codes.add(run.code)
    assert codes == {-1, 0, 1, 2, 3}  # every label, unknown and undetermined included, was exercised


def test_replicate_scatter_beyond_the_quoted_errors_lowers_the_confidence():
    """Two replicates D_eff_cr = 2e-4 and 1.6e-3 (+- 1e-5 each, intact cages): their mean
    9e-4 with the propagated error 7e-6 would read solid; the scatter inflates the error
    by sqrt(chi2/dof) = 99 to 7e-4, P(solid) = 0.56: undetermined."""
    base = {"cage_msd_ratio": 0.02, "cage_msd_ratio_err": 0.01, "msd_long_enough": 1.0, "msd_diffusive": 1.0,
            "D_eff_cr_err": 1e-5, "q_mean": 3.6, "q_mean_err": 0.01, "rho_d": 0.2, "rho_d_err": 0.01}
    runs = [dict(base, D_eff_cr=2e-4), dict(base, D_eff_cr=1.6e-3)]
    lab, _ = point_labels(runs)
    assert lab.code == PHASE_UNDETERMINED and 0.5 < lab.confidence < 0.6, lab.reason
    agreeing = [dict(base, D_eff_cr=2e-4), dict(base, D_eff_cr=2.1e-4)]
    assert point_labels(agreeing)[0].code == PHASE_SOLID


def test_starts_agree_only_where_every_present_start_decides_alike():
    codes = np.array([[0, 0], [0, 1], [1, 3], [3, -1], [-1, -1], [2, -1]])
    conf = np.array([[0.99, 0.97], [0.99, 0.99], [0.98, 0.6], [0.7, np.nan], [np.nan, np.nan], [0.96, np.nan]])
    code, c, hyst = agree(codes, conf, (0, 1, 2), 3)
    assert code.tolist() == [0, 3, 3, 3, -1, 2]
    assert c[0] == 0.97 and c[5] == 0.96 and np.all(np.isnan(c[1:5]))
    assert hyst.tolist() == [HYSTERESIS_AGREE, HYSTERESIS_DISAGREE, HYSTERESIS_ONE_SIDED, HYSTERESIS_ONE_SIDED,
                             -1, HYSTERESIS_ONE_SIDED]


def _two_start_dataset():
    """eta x v0 x N x initial x replicate; per v0: both starts solid; lattice solid and
    disordered fluid; lattice fluid and disordered not trusted (undetermined)."""
    dims = ("eta", "v0", "N", "initial", "replicate")
    coords = {"eta": [0.1], "v0": [0.01, 0.02, 0.03], "N": [64], "initial": ["disordered", "lattice"],
              "replicate": [0, 1]}
    shape = tuple(len(v) for v in coords.values())
    solid = {"cage_msd_ratio": 0.02, "cage_msd_ratio_err": 0.01, "D_eff_cr": 1e-5, "D_eff_cr_err": 1e-5,
             "msd_long_enough": 1.0, "msd_diffusive": 1.0, "rho_d": 0.1, "rho_d_err": 0.01}
    fluid = {"cage_msd_ratio": 3.0, "cage_msd_ratio_err": 0.1, "D_eff_cr_late": 5e-3, "D_eff_cr_late_err": 5e-4,
             "D_eff_cr": 6e-3, "D_eff_cr_err": 6e-4, "msd_long_enough": 1.0, "msd_diffusive": 1.0,
             "rho_d": 0.7, "rho_d_err": 0.01}
    untrusted = dict(solid, msd_long_enough=0.0)
    table = {(0, 0): solid, (0, 1): solid, (1, 0): fluid, (1, 1): solid, (2, 0): untrusted, (2, 1): fluid}
    ds = xr.Dataset(coords=coords)
    for v in POINT_INPUTS + ("q_mean", "q_mean_err"):
        arr = np.full(shape, np.nan)
        for (iv, ii), sc in table.items():
            arr[0, iv, 0, ii, :] = dict(sc, q_mean=3.6, q_mean_err=0.01).get(v, np.nan)
        ds[v] = (dims, arr)
    ds["status"] = (dims, np.zeros(shape, dtype=np.int8))
    ds["phase"] = (dims, np.zeros(shape, dtype=np.int8))
    ds["kthny"] = (dims, np.full(shape, 3, dtype=np.int8))
    ds["kthny_confidence"] = (dims, np.full(shape, 0.6))
    return ds


def test_both_starts_give_per_start_labels_a_common_point_label_and_hysteresis():
    ds = _two_start_dataset()
    add_point_labels(ds, 0.95, 0.5)
    assert ds["phase_start"].dims == ("eta", "v0", "N", "initial")
    assert "initial" not in ds["phase_point"].dims and "initial" not in ds["phase_hysteresis"].dims
    start = ds["phase_start"].isel(eta=0, N=0).values  # (v0, initial: disordered, lattice)
    assert start.tolist() == [[PHASE_SOLID, PHASE_SOLID], [PHASE_FLUID, PHASE_SOLID],
                              [PHASE_UNDETERMINED, PHASE_FLUID]]
    point = ds["phase_point"].isel(eta=0, N=0).values
    assert point.tolist() == [PHASE_SOLID, PHASE_UNDETERMINED, PHASE_UNDETERMINED]
    conf = ds["phase_point_confidence"].isel(eta=0, N=0).values
    assert conf[0] == pytest.approx(ds["phase_start_confidence"].isel(eta=0, N=0, v0=0).min())
    hyst = ds["phase_hysteresis"].isel(eta=0, N=0).values
    assert hyst.tolist() == [HYSTERESIS_AGREE, HYSTERESIS_DISAGREE, HYSTERESIS_ONE_SIDED]
    assert ds["phase_hysteresis"].attrs["flag_meanings"] == "unknown agree disagree one_sided"
    perc = ds["percolated_point"].isel(eta=0, N=0).values
    assert perc.tolist() == [0, 2, 2]  # rho_d 0.1 / 0.1, 0.7 / 0.1, 0.1 / 0.7
    assert ds["kthny_start"].dims == ds["phase_start"].dims and ds["kthny_point"].dims == ds["phase_point"].dims


def test_without_initial_the_point_labels_keep_their_dimensions():
    ds = _two_start_dataset().isel(initial=1, drop=True)
    add_point_labels(ds, 0.95, 0.5)
    assert ds["phase_point"].dims == ("eta", "v0", "N") and "phase_hysteresis" not in ds
    assert ds["phase_point"].isel(eta=0, N=0).values.tolist() == [PHASE_SOLID, PHASE_SOLID, PHASE_FLUID]


def test_the_config_analysis_section_reaches_the_analysis_settings():
    """analysis.label_confidence / percolation_threshold are validated, stored with the
    config, and become the settings analyze, aggregate and the run.until check use."""
    from fcsweep.results.analyze import DEFAULT_SETTINGS, config_settings, settings_with
    from fcsweep.config import ConfigError, json_schema, parse_config

    text = ("output: out\ngrid: {eta: [0.1]}\nmodel: {N: 16, v0: 0.01}\nrun: {steps: 100, sample_every: 10, "
            "checkpoint_every: 50, until: {check_every: 50, confidence: 0.9}}\n")
    cfg = parse_config(text + "analysis: {label_confidence: 0.9, percolation_threshold: 0.4}\n")
    s = settings_with(config_settings(cfg), transient=0.2)
    assert s["label_confidence"] == 0.9 and s["percolation_threshold"] == 0.4
    assert cfg.to_dict()["analysis"] == {"label_confidence": 0.9, "percolation_threshold": 0.4}
    assert DEFAULT_SETTINGS["label_confidence"] == 0.95 and DEFAULT_SETTINGS["percolation_threshold"] == 0.5
    with pytest.raises(ConfigError, match=r"run.until.confidence = 0.9 is below analysis.label_confidence = 0.95"):
        parse_config(text)
    props = json_schema()["properties"]["analysis"]["properties"]
    assert props["label_confidence"]["exclusiveMinimum"] == 0.5
    assert props["percolation_threshold"]["exclusiveMaximum"] == 1


def test_solid_kind_tells_a_crystal_from_a_glass():
    """The both-starts numbers of eta = 0.08, v0 = 0.02 at N = 1024: |Psi6| 0.96, rho_d 0 from
    the lattice (a crystal), 0.51, 0.061 from the disordered start (amorphous)."""
    from fcsweep.analysis.phase import solid_kind

    assert solid_kind(PHASE_SOLID, 0.960, 0.002, 0.0, 0.0) == (0, 1.0)
    kind, p = solid_kind(PHASE_SOLID, 0.511, 0.02, 0.061, 0.004)
    assert kind == 1 and p > 0.999
    assert solid_kind(PHASE_SOLID, 0.70, 0.05, 0.0, 0.0)[0] == 2  # on the line: undetermined
    assert solid_kind(PHASE_FLUID, 0.96, 0.002, 0.0, 0.0)[0] == -1  # only solids have a kind


def test_a_crystal_and_a_glass_are_not_the_same_state():
    """Both starts read solid; with |Psi6| and rho_d of a crystal from one and of a glass from
    the other, the point is undetermined, phase_hysteresis disagree, reason solid_kinds_differ."""
    from fcsweep.analysis.reasons import reason_value

    ds = _two_start_dataset()
    psi = np.full(ds["rho_d"].shape, np.nan)
    psi[..., 0, :], psi[..., 1, :] = 0.5, 0.95  # disordered, lattice
    ds["psi6"], ds["psi6_err"] = (ds["rho_d"].dims, psi), (ds["rho_d"].dims, np.full(psi.shape, 0.01))
    rho = ds["rho_d"].values.copy()
    rho[0, 0, 0, 1, :] = 0.0  # the lattice start of v0 = 0.01 has no defects
    ds["rho_d"].values[:] = rho
    ds["rho_d_err"].values[0, 0, 0, 1, :] = 0.0
    add_point_labels(ds, 0.95, 0.5)
    kinds = ds["solid_kind_start"].isel(eta=0, N=0, v0=0).values.tolist()  # (disordered, lattice)
    assert kinds == [1, 0]
    assert ds["phase_point"].isel(eta=0, N=0, v0=0).item() == PHASE_UNDETERMINED
    assert np.isnan(ds["phase_point_confidence"].isel(eta=0, N=0, v0=0).item())
    assert ds["phase_hysteresis"].isel(eta=0, N=0, v0=0).item() == HYSTERESIS_DISAGREE
    assert ds["phase_point_reason_code"].isel(eta=0, N=0, v0=0).item() == reason_value("solid_kinds_differ")
    # the same glass from both starts is one state: solid, amorphous
    ds2 = _two_start_dataset()
    ds2["psi6"], ds2["psi6_err"] = (ds2["rho_d"].dims, np.full(psi.shape, 0.5)), (ds2["rho_d"].dims,
                                                                                  np.full(psi.shape, 0.01))
    add_point_labels(ds2, 0.95, 0.5)
    assert ds2["phase_point"].isel(eta=0, N=0, v0=0).item() == PHASE_SOLID
    assert ds2["solid_kind_point"].isel(eta=0, N=0, v0=0).item() == 1
