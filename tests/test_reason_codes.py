"""Reason codes of the labels (:mod:`fcsweep.analysis.reasons`): every branch of the phase,
percolation, KTHNY and point rules sets a declared code that says what its reason text
says; the codes are stored per run (analysis.h5, an int8 HDF5 enum) and per run, start and
point in the dataset (int8 CF flags); the phase diagram writes a point's words from its
code, from the text only where a dataset has no code."""

from __future__ import annotations

import re

import h5py
import matplotlib
import numpy as np
import pytest
import xarray as xr
from results_sweep import analysed, sweep  # noqa: F401  (fixtures: a 4-run analysed sweep, a copy per test)
from test_figures import synthetic_dataset, with_statistics

from fcsweep.results import figures as plots
from fcsweep.analysis.kthny import classify_kthny
from fcsweep.analysis.phase import (KTHNY_HEXATIC, KTHNY_LIQUID, KTHNY_UNDETERMINED, KTHNY_UNKNOWN, PHASE_FLUID,
                                    PHASE_SOFT_FLUID, PHASE_SOLID, PHASE_UNDETERMINED, PHASE_UNKNOWN, Label,
                                    PhaseEvidence, classify_percolation, classify_phase, phase_evidence,
                                    phase_label)
from fcsweep.analysis.points import common_reason, point_labels
from fcsweep.analysis.reasons import FAMILIES, REASON_BY_NAME, REASONS, reason_flags, reason_name, reason_value
from fcsweep.config import parse_config
from fcsweep.measure.labels import movie_labels

nan = float("nan")

#: What the reason text of each code must say (a regex over the text the rules write).
TEXT_OF = {
    "not_available": r"not available|no cage test",
    "no_error": r"no error",
    "too_short": r"too short",
    "not_diffusive": r"not diffusive|not trustworthy|not settled",
    "fluid_cages_intact": r"reads fluid.*(no cage broken|no evidence)",
    "near_d_threshold": r"too close to the solid threshold",
    "cages_may_be_broken": r"cages may be\s+broken",
    "few_late_lags": r"too few lags past the breaking",
    "near_q_star": r"<q>.*too close",
    "solid_cages_intact": r"^P\(solid\)",
    "decided_cages_broken": r"^cages broken .*: P\((solid|fluid|soft-fluid)\)",
    "decided_d_eff": r"^P\((solid|fluid|soft-fluid)\)",
    "decided_q_no_d_eff": r"cages broken .*D_eff unknown.*: P\(",
    "cages_intact_no_d_eff": r"cages not broken.*solid needs D_eff",
    "near_rho_threshold": r"rho_d .*too close",
    "decided_rho_d": r"^P\((not_)?percolated\)",
    "no_analysed_run": r"no analysed run",
    "too_few_cells": r"N = \d+ < \d+",
    "g6_noise_untestable": r"G6 fell into its noise",
    "g6_not_fitted": r"G6 could not be fitted",
    "cg1_not_computed": r"C_G1 not computed",
    "cg1_noise_untestable": r"C_G1 fell into its noise",
    "cg1_not_fitted": r"C_G1 could not be fitted",
    "near_kthny_bounds": r"P\(\w+\) = [\d.]+ < ",
    "decided_exponents": r"^P\((solid|hexatic|liquid)\) = ",
}


def _check(label: Label, code: int, reason_code: str, family: str) -> None:
    assert label.code == code, label
    assert label.reason_code == reason_code, label
    assert re.search(TEXT_OF[reason_code], label.reason), label
    assert reason_value(reason_code) in reason_flags(family)


def test_the_table_is_well_formed():
    codes = [r.code for r in REASONS]
    assert len(set(codes)) == len(codes) and len({r.name for r in REASONS}) == len(REASONS)
    assert all(-128 <= c <= 127 for c in codes)  # stored as int8
    assert all(re.fullmatch(r"[a-z0-9_]+", r.name) for r in REASONS)  # a CF flag_meanings word
    assert all(set(r.labels) <= set(FAMILIES) for r in REASONS)
    assert reason_name(0) == "not_recorded" and reason_name(99) == "not_recorded"
    # every code a figure would explain (an undetermined reason) has its words
    decided = {"not_recorded", "solid_cages_intact", "decided_cages_broken", "decided_d_eff",
               "decided_q_no_d_eff", "decided_rho_d", "decided_exponents", "replicates_agree", "starts_agree",
               "decided_relaxed"}
    assert all(bool(r.short) == (r.name not in decided) for r in REASONS)
    assert set(TEXT_OF) <= set(REASON_BY_NAME)
    with pytest.raises(ValueError, match="undeclared reason code"):
        Label(0, 1.0, "P(solid) = 1", "because")


def _ev(**kw) -> PhaseEvidence:
    base = dict(D_solid=1e-5, D_solid_err=1e-6, solid_trusted=True, trust_note="", p_broken=0.01, cage_note="",
                D_late=nan, D_late_err=nan, q=3.6, q_err=0.01)
    return PhaseEvidence(**{**base, **kw})


BROKEN = dict(p_broken=0.999)


@pytest.mark.parametrize("ev, code, reason_code", [
    # cages broken: D_eff_cr_late and <q> decide
    (_ev(**BROKEN), PHASE_UNDETERMINED, "few_late_lags"),
    (_ev(**BROKEN, D_late=0.1), PHASE_UNDETERMINED, "no_error"),
    (_ev(**BROKEN, D_late=1e-4, D_late_err=1e-5), PHASE_SOLID, "decided_cages_broken"),
    (_ev(**BROKEN, D_late=1e-3, D_late_err=1e-3), PHASE_UNDETERMINED, "near_d_threshold"),
    (_ev(**BROKEN, D_late=0.1, D_late_err=1e-3, q=nan), PHASE_UNKNOWN, "not_available"),
    (_ev(**BROKEN, D_late=0.1, D_late_err=1e-3, q=3.9, q_err=nan), PHASE_UNDETERMINED, "no_error"),
    (_ev(**BROKEN, D_late=0.1, D_late_err=1e-3, q=3.81, q_err=0.1), PHASE_UNDETERMINED, "near_q_star"),
    (_ev(**BROKEN, D_late=0.1, D_late_err=1e-3), PHASE_FLUID, "decided_cages_broken"),
    (_ev(**BROKEN, D_late=0.1, D_late_err=1e-3, q=4.2), PHASE_SOFT_FLUID, "decided_cages_broken"),
    # cages not broken: only a trusted D_eff_cr decides, and only "solid"
    (_ev(), PHASE_SOLID, "solid_cages_intact"),
    (_ev(p_broken=0.5), PHASE_UNDETERMINED, "cages_may_be_broken"),
    (_ev(D_solid=nan), PHASE_UNKNOWN, "not_available"),
    (_ev(D_solid_err=nan), PHASE_UNDETERMINED, "no_error"),
    (_ev(D_solid=0.1, D_solid_err=1e-3), PHASE_UNDETERMINED, "fluid_cages_intact"),
    (_ev(D_solid=1e-3, D_solid_err=1e-3), PHASE_UNDETERMINED, "near_d_threshold"),
])
def test_every_branch_of_the_phase_rule_sets_a_code_its_text_says(ev, code, reason_code):
    _check(phase_label(ev), code, reason_code, "phase")


@pytest.mark.parametrize("flags, reason_code", [
    ({"msd_long_enough": 0.0, "msd_diffusive": 1.0}, "too_short"),
    ({"msd_long_enough": 1.0, "msd_diffusive": 0.0}, "not_diffusive"),
])
def test_an_untrusted_d_eff_says_why_by_the_flags(flags, reason_code):
    sc = {"D_eff": 1e-5, "D_eff_err": 1e-6, "q_mean": 3.6, "q_mean_err": 0.01, "cage_msd_ratio": 0.01,
          "cage_msd_ratio_err": 0.01, "cage_lag": 10.0, "rho_d": 0.1, "rho_d_err": 0.01, **flags}
    _check(phase_label(phase_evidence(sc)), PHASE_UNDETERMINED, reason_code, "phase")
    # a point's wording of several replicates keeps the code of the least favourable one
    phase, _ = point_labels([sc, {**sc, "msd_long_enough": 1.0, "msd_diffusive": 1.0}])
    _check(phase, PHASE_UNDETERMINED, reason_code, "phase")


@pytest.mark.parametrize("args, kw, code, reason_code", [
    ((nan, nan, 3.6, 0.01), {}, PHASE_UNKNOWN, "not_available"),
    ((0.1, nan, 3.6, 0.01), {}, PHASE_UNDETERMINED, "no_error"),
    ((0.1, 1e-3, nan, nan), {}, PHASE_UNKNOWN, "not_available"),
    ((0.1, 1e-3, 3.6, nan), {}, PHASE_UNDETERMINED, "no_error"),
    ((0.1, 1e-3, 3.6, 0.01), {"diffusion_ok": False}, PHASE_UNDETERMINED, "not_diffusive"),
    ((0.1, 1e-3, 3.6, 0.01), {"diffusion_ok": False, "diffusion_note": "run too short",
                              "diffusion_code": "too_short"}, PHASE_UNDETERMINED, "too_short"),
    ((1e-3, 1e-3, 3.6, 0.01), {}, PHASE_UNDETERMINED, "near_d_threshold"),
    ((0.1, 1e-3, 3.81, 0.1), {}, PHASE_UNDETERMINED, "near_q_star"),
    ((0.1, 1e-3, 3.6, 0.01), {}, PHASE_FLUID, "decided_d_eff"),
    ((1e-5, 1e-6, nan, nan), {}, PHASE_SOLID, "decided_d_eff"),
])
def test_the_plain_d_eff_test_sets_codes_too(args, kw, code, reason_code):
    _check(classify_phase(*args, **kw), code, reason_code, "phase")


@pytest.mark.parametrize("rho, err, code, reason_code", [
    (nan, 0.01, -1, "not_available"), (0.7, nan, 2, "no_error"), (0.5, 0.1, 2, "near_rho_threshold"),
    (0.7, 0.01, 1, "decided_rho_d"), (0.2, 0.01, 0, "decided_rho_d"),
])
def test_every_branch_of_the_percolation_rule_sets_a_code(rho, err, code, reason_code):
    _check(classify_percolation(rho, err), code, reason_code, "percolated")


def _fits(**kw) -> dict:
    base = {"eta_6": 0.1, "eta_6_err": 0.01, "eta_G1": 0.1, "eta_G1_err": 0.01, "G1_computed": True,
            "G1_errors": True}
    return {**base, **kw}


@pytest.mark.parametrize("fits, n, code, reason_code", [
    (_fits(), 100, KTHNY_UNDETERMINED, "too_few_cells"),
    (_fits(six_sunk=True, six_p_bound=nan), None, KTHNY_UNDETERMINED, "g6_noise_untestable"),
    (_fits(eta_6=nan), None, KTHNY_UNKNOWN, "g6_not_fitted"),
    (_fits(G1_computed=False), None, KTHNY_UNDETERMINED, "cg1_not_computed"),
    (_fits(G1_errors=False), None, KTHNY_UNDETERMINED, "no_error"),
    (_fits(G1_sunk=True, G1_p_bound=nan), None, KTHNY_UNDETERMINED, "cg1_noise_untestable"),
    (_fits(eta_G1=nan), None, KTHNY_UNDETERMINED, "cg1_not_fitted"),
    (_fits(eta_6=0.25, eta_6_err=0.05), None, KTHNY_UNDETERMINED, "near_kthny_bounds"),
    (_fits(eta_G1=0.8), None, KTHNY_HEXATIC, "decided_exponents"),
    (_fits(eta_6=0.8, G1_computed=False), None, KTHNY_LIQUID, "decided_exponents"),
])
def test_every_branch_of_the_kthny_rule_sets_a_code(fits, n, code, reason_code):
    _check(classify_kthny(fits, n_cells=n), code, reason_code, "kthny")


def test_movie_labels_carry_codes():
    base = {"rho_d_movie": 0.2, "rho_d_movie_err": 0.01, "q_mean_movie": 3.6, "q_mean_movie_err": 0.01,
            "D_eff": nan, "D_eff_err": nan, "D_s_diffusive": 0}
    cases = ((0.2, PHASE_UNDETERMINED, "cages_intact_no_d_eff"), (nan, PHASE_UNKNOWN, "not_available"),
             (0.999, PHASE_FLUID, "decided_q_no_d_eff"))
    for p, code, reason_code in cases:
        code_, _, text, _ = movie_labels({**base, "cage_broken_probability": p}, threshold=0.5)["phase"]
        assert code_ == code and re.search(TEXT_OF[reason_code], text)


def test_a_point_without_runs_and_the_common_reason_of_several():
    ph, pc = point_labels([])
    _check(ph, -1, "no_analysed_run", "phase")
    _check(pc, -1, "no_analysed_run", "percolated")
    v = reason_value
    dec = (0, 1, 2)
    rows = [  # common label, entries' labels, entries' reasons, expected
        (0, [0, 0], [v("decided_exponents")] * 2, "decided_exponents"),
        (0, [0, 0], [v("decided_cages_broken"), v("solid_cages_intact")], "replicates_agree"),
        (3, [0, 2], [v("decided_exponents")] * 2, "replicates_disagree"),
        (3, [0, 3], [v("decided_exponents"), v("near_kthny_bounds")], "near_kthny_bounds"),
        (3, [0, -1], [v("decided_exponents"), v("not_analysed")], "not_analysed"),
        (-1, [-1, -1], [v("not_analysed")] * 2, "no_analysed_run"),
        (-1, [-1, -1], [v("not_analysed"), v("g6_not_fitted")], "g6_not_fitted"),
    ]
    got = common_reason(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                        np.array([r[2] for r in rows]), dec, disagree="replicates_disagree",
                        agree_="replicates_agree")
    assert [reason_name(c) for c in got] == [r[3] for r in rows]


# ------------------------------------------------------------------ stored: analysis.h5 and the dataset

def test_codes_are_stored_per_run_and_point_as_cf_flags(sweep):  # noqa: F811
    from fcsweep.results.aggregate import build_dataset
    from fcsweep.results.analyze import read_analysis

    cfg_file, sweep, _ = sweep
    h5s = sorted(sweep.glob("runs/*/analysis.h5"))
    for path in h5s:
        with h5py.File(path, "r") as f:
            for lab in FAMILIES:
                name = f"{lab}_reason_code"
                enum = h5py.check_enum_dtype(f["observables"].attrs.get_id(name).dtype)
                assert enum == {n: c for c, n in reason_flags(lab).items()}
                assert f["observables"].attrs[name].dtype == np.int8
        sc = read_analysis(path)["scalars"]
        for lab in FAMILIES:  # the code says what the text says
            name = reason_name(sc[f"{lab}_reason_code"])
            assert name in TEXT_OF and re.search(TEXT_OF[name], sc[f"{lab}_reason"]), (lab, name, sc[f"{lab}_reason"])
    with xr.open_dataset(sweep / "phase_diagram.nc") as ds:
        ds.load()
    for lab in FAMILIES:
        for var in (f"{lab}_reason_code", f"{lab}_point_reason_code"):
            da = ds[var]
            assert da.dtype == np.int8
            words = dict(zip(da.attrs["flag_values"].tolist(), da.attrs["flag_meanings"].split()))
            assert words == reason_flags(lab)
            assert set(np.unique(da.values).tolist()) <= set(words)
        # a point of one replicate: its point label and reason code are its run's
        assert (ds[f"{lab}_point_reason_code"].values == ds[f"{lab}_reason_code"].isel(replicate=0).values).all()
    decided = ds["phase"].values != PHASE_UNDETERMINED
    names = np.vectorize(reason_name)(ds["phase_reason_code"].values)
    assert all(n.startswith(("decided", "solid")) == d for n, d in zip(names.ravel(), decided.ravel()))
    # an analysis.h5 older than the codes: not_recorded in the dataset, the text stays
    with h5py.File(h5s[0], "a") as f:
        for lab in FAMILIES:
            del f["observables"].attrs[f"{lab}_reason_code"]
    old = build_dataset(parse_config(cfg_file.read_text()))
    codes = old["phase_reason_code"].values.ravel()
    assert sorted(codes.tolist()).count(reason_value("not_recorded")) == 1
    assert (old["phase_reason"].values != "").all()


# ------------------------------------------------------------------ the figure reads the code

def test_the_phase_diagram_takes_its_words_from_the_code_and_the_text_only_without_one():
    ds = with_statistics(synthetic_dataset())
    ds["phase"][...] = PHASE_FLUID
    for i, j in ((1, 1), (2, 0), (0, 2)):
        ds["phase"][i, j] = PHASE_UNDETERMINED
    text = np.full(ds["phase"].shape, "", dtype=object)
    text[0, 2] = "<q> = 3.8 +- 0.02 too close to 3.81 (P = 0.61 < 0.84)"
    ds["phase_reason"] = (ds["phase"].dims, text)
    code = np.full(ds["phase"].shape, reason_value("decided_d_eff"), dtype=np.int8)
    code[1, 1], code[2, 0], code[0, 2] = reason_value("too_short"), reason_value("few_late_lags"), 0
    ds["phase_reason_code"] = (ds["phase"].dims, code)
    ax = plots.phase_diagram(ds).axes[0]
    texts = sorted(t.get_text().replace("\n", " ") for t in ax.texts if t.get_gid() == "reason")
    # blank text, code set: the code's words; code not_recorded: the text's
    assert texts == ["<q> near 3.81", "few lags past breaking", "too short"]
    matplotlib.pyplot.close("all")


def test_start_and_point_reason_codes_of_two_starts():
    from test_point_labels import _two_start_dataset

    from fcsweep.results.aggregate import add_point_labels

    ds = _two_start_dataset()
    add_point_labels(ds, 0.95, 0.5)
    start = np.vectorize(reason_name)(ds["phase_start_reason_code"].isel(eta=0, N=0).values)
    # per v0 (disordered, lattice): both solid; fluid / solid; too short / fluid
    assert start.tolist() == [["solid_cages_intact"] * 2, ["decided_cages_broken", "solid_cages_intact"],
                              ["too_short", "decided_cages_broken"]]
    point = [reason_name(c) for c in ds["phase_point_reason_code"].isel(eta=0, N=0).values]
    assert point == ["solid_cages_intact", "starts_disagree", "too_short"]
    for k in FAMILIES:
        for v in (f"{k}_start_reason_code", f"{k}_point_reason_code"):
            assert ds[v].attrs["flag_meanings"].split() == list(reason_flags(k).values())


def test_the_figure_words_over_starts_and_replicates():
    from fcsweep.results.figures.diagrams import _point_reasons
    from fcsweep.analysis.phase import PHASE_FLAGS, flag_attrs

    dims = ("eta", "v0", "initial", "replicate")
    ds = xr.Dataset(coords={"eta": [0.1], "v0": [0.01, 0.02, 0.03], "initial": ["disordered", "lattice"],
                            "replicate": [0, 1]})
    S, F, U = PHASE_SOLID, PHASE_FLUID, PHASE_UNDETERMINED
    phase = np.array([[[[S, S], [F, F]], [[S, F], [F, F]], [[S, S], [S, U]]]], dtype=np.int8)
    code = np.full(phase.shape, reason_value("decided_cages_broken"), dtype=np.int8)
    code[0, 2, 1, 1] = reason_value("too_short")
    ds["phase"] = (dims, phase, flag_attrs(PHASE_FLAGS))
    ds["phase_reason_code"] = (dims, code)
    words = _point_reasons(ds, ("v0", "eta"), None)[:, 0].tolist()
    assert words == ["starts disagree", "replicates disagree", "too short"]


def test_the_reason_names_the_estimate_the_solid_test_read():
    """Near the threshold the reason quotes D_eff_cr when the cage-relative estimate decided,
    not the plain D_eff beside it (0.0102 there: a reader would see no conflict with 1e-3)."""
    from fcsweep.analysis.phase import phase_evidence, phase_label

    sc = {"D_eff": 0.0102, "D_eff_err": 0.0039, "D_eff_cr": 0.000538, "D_eff_cr_err": 0.00043,
          "msd_long_enough": 1.0, "msd_diffusive": 1.0, "q_mean": 3.7, "q_mean_err": 0.001}
    lab = phase_label(phase_evidence(sc))
    assert lab.reason_code == "near_d_threshold"
    assert "D_eff_cr = 0.000538" in lab.reason and "D_eff = " not in lab.reason.replace("D_eff_cr = ", "")
    plain = phase_label(phase_evidence({**sc, "D_eff_cr": float("nan"), "D_eff": 0.0011, "D_eff_err": 0.0004}))
    assert plain.reason.startswith("D_eff = 0.0011")
