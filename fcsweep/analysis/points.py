"""Labels of a grid point: the one phase rule on its replicate-combined evidence, and the
agreement of its two starts (``initial``: lattice, disordered) where the grid has both.

A point's evidence (:func:`combine_runs`) is what the phase rule reads for a run, with
every number the replicate mean of :func:`fcsweep.analysis.stats.combine` (its error
scaled up by ``sqrt(chi2/dof)`` when the replicates scatter more than their errors allow)
and every trust flag the least favourable replicate's. A point with one replicate thus
carries its run's label and confidence (:func:`point_labels`, the function the aggregate
calls per point).

With an ``initial`` dimension the labels per start (``phase_start``, ...) come from that
rule, and the point's label (``phase_point``, ...) is the starts' common decided label
with the smaller confidence, else undetermined; ``phase_hysteresis`` says whether the
starts agree (:data:`HYSTERESIS_FLAGS`).
"""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.phase import (KTHNY_UNDETERMINED, MIN_CONFIDENCE, PERCOLATION_UNDETERMINED,
                                    PHASE_UNDETERMINED, RHO_D_PERCOLATION, Label, classify_percolation,
                                    phase_evidence, phase_label)
from fcsweep.analysis.reasons import reason_value
from fcsweep.analysis.stats import combine

#: Numbers the labels read, combined over replicates (each with ``<name>_err``).
COMBINED = ("D_eff", "D_eff_long", "D_eff_cr", "D_eff_cr_late", "cage_msd_ratio", "q_mean", "rho_d", "psi6",
            "F_s_bound")
#: Trust flags and counts: a point takes the smallest over its replicates.
LEAST = ("msd_long_enough", "msd_diffusive", "n_time_blocks")
#: Flags of the point's evidence taken as the largest over its replicates (NaN counts as 0).
MOST = ("msd_bounded", "equilibration_at_limit")
#: Codes and CF flag meanings of ``phase_hysteresis``.
HYSTERESIS_UNKNOWN, HYSTERESIS_AGREE, HYSTERESIS_DISAGREE, HYSTERESIS_ONE_SIDED = -1, 0, 1, 2
HYSTERESIS_FLAGS = {HYSTERESIS_UNKNOWN: "unknown", HYSTERESIS_AGREE: "agree", HYSTERESIS_DISAGREE: "disagree",
                    HYSTERESIS_ONE_SIDED: "one_sided"}


def combine_runs(runs) -> dict:
    """The evidence of a grid point from its analysed runs' scalars.

    Parameters
    ----------
    runs : sequence of dict
        Scalars of each analysed replicate (names of ``analysis.h5``).

    Returns
    -------
    dict
        ``<name>``, ``<name>_err`` for :data:`COMBINED` (replicate mean and its error),
        the smallest of each of :data:`LEAST` and the largest of each of :data:`MOST`
        (NaN counts as 0), ``cage_lag`` (mean).
    """
    runs = list(runs)
    out = {}
    for v in COMBINED:
        c = combine([r.get(v, np.nan) for r in runs], [r.get(f"{v}_err", np.nan) for r in runs])
        out[v], out[f"{v}_err"] = c.mean, c.err
    for v in LEAST:
        vals = [float(r.get(v, np.nan)) for r in runs]
        out[v] = float(np.min(np.nan_to_num(vals, nan=0.0))) if vals else float("nan")
    for v in MOST:
        vals = [float(r.get(v, np.nan)) for r in runs]
        out[v] = float(np.max(np.nan_to_num(vals, nan=0.0))) if vals else float("nan")
    for lo, hi in (("q_bias_low", "q_bias_high"), ("d_bias_low", "d_bias_high")):  # the widest range
        def value(r, k):  # NaN (not recorded) reads as no offset; +-inf (not measured) stays
            return float(np.nan_to_num(float(r.get(k, 0.0)), nan=0.0, posinf=np.inf, neginf=-np.inf))

        out[lo], out[hi] = min(value(r, lo) for r in runs), max(value(r, hi) for r in runs)
    lags = [float(r.get("cage_lag", np.nan)) for r in runs]
    out["cage_lag"] = float(np.nanmean(lags)) if np.any(np.isfinite(lags)) else float("nan")
    return out


def point_labels(runs, *, min_confidence: float = MIN_CONFIDENCE,
                 percolation_threshold: float = RHO_D_PERCOLATION) -> tuple[Label, Label]:
    """Phase and percolation labels of a grid point from its analysed runs' scalars.

    Returns
    -------
    phase, percolated : Label
        Unknown (-1) where no run was analysed.
    """
    runs = list(runs)
    if not runs:
        nan = float("nan")
        return (Label(-1, nan, "no analysed run", "no_analysed_run"),
                Label(-1, nan, "no analysed run", "no_analysed_run"))
    sc = combine_runs(runs)
    note = None
    if len(runs) > 1:  # the flags are the least favourable replicate's: the code says which failed
        note = ("a replicate's run is too short for D_eff" if not sc["msd_long_enough"] >= 0.5
                else "a replicate's D_eff is not trustworthy (MSD not diffusive)")
    phase = phase_label(phase_evidence(sc, note), min_confidence=min_confidence)
    perc = classify_percolation(sc["rho_d"], sc["rho_d_err"], min_confidence=min_confidence,
                                threshold=percolation_threshold, stationary=not sc["equilibration_at_limit"] >= 0.5)
    return phase, perc


def agree(codes, confidences, decided, undetermined: int):
    """The common label of several starts (last axis): a decided code that every present
    start (code >= 0) has, with their smallest confidence; else ``undetermined``; -1
    where no start is present.

    Returns
    -------
    code : ndarray of int8
    confidence : ndarray of float
    hysteresis : ndarray of int8
        :data:`HYSTERESIS_FLAGS`: disagree where two decided starts differ, agree where
        every start is present and decided alike (two or more), one_sided where only one
        start is decided or present, unknown where none is decided.
    """
    k = np.asarray(codes)
    c = np.asarray(confidences, dtype=float)
    present = k >= 0
    dec = np.isin(k, list(decided))
    n_dec = dec.sum(axis=-1)
    big, small = np.iinfo(np.int16).max, np.iinfo(np.int16).min
    hi = np.where(dec, k, small).max(axis=-1)
    lo = np.where(dec, k, big).min(axis=-1)
    all_same = (n_dec == present.sum(axis=-1)) & (n_dec >= 1) & (hi == lo)
    code = np.where(all_same, hi, np.where(present.any(axis=-1), undetermined, -1)).astype(np.int8)
    cmin = np.min(np.where(dec & np.isfinite(c), c, np.inf), axis=-1)
    conf = np.where(all_same & np.isfinite(cmin), cmin, np.nan)
    hyst = np.full(code.shape, HYSTERESIS_UNKNOWN, dtype=np.int8)
    hyst[n_dec == 1] = HYSTERESIS_ONE_SIDED
    hyst[(n_dec >= 2) & (hi == lo) & (n_dec == k.shape[-1])] = HYSTERESIS_AGREE
    hyst[(n_dec >= 2) & (hi == lo) & (n_dec < k.shape[-1])] = HYSTERESIS_ONE_SIDED
    hyst[(n_dec >= 2) & (hi != lo)] = HYSTERESIS_DISAGREE
    hyst[(n_dec == 0) & (present.sum(axis=-1) == 1)] = HYSTERESIS_ONE_SIDED
    return code, conf, hyst


def common_reason(point, codes, reasons, decided, *, disagree: str, agree_: str):
    """Reason code of a label common to several replicates or starts (last axis of
    ``codes``), beside that common label ``point`` (:func:`agree`, or the replicates' rule).

    Parameters
    ----------
    point : array of int
        The common label.
    codes, reasons : array of int
        Label codes of the entries (-1: absent or unknown) and their stored reason codes
        (:data:`fcsweep.analysis.reasons.REASONS`).
    decided : sequence of int
        The decided label codes.
    disagree, agree_ : str
        Reason names for decided entries that differ (``replicates_disagree``,
        ``starts_disagree``) and for one decided label given for different reasons.

    Returns
    -------
    ndarray of int8
        A decided ``point``: the common reason of the entries that give it, else
        ``agree_``. Otherwise ``disagree`` where two decided entries differ, else the reason
        of the first entry that is not decided (a present one first), ``no_analysed_run``
        where no entry was analysed.
    """
    pt, k, rc = np.asarray(point), np.asarray(codes), np.asarray(reasons)
    nothing = (reason_value("not_analysed"), reason_value("no_analysed_run"))
    out = np.full(pt.shape, reason_value("no_analysed_run"), dtype=np.int8)
    for idx in np.ndindex(out.shape):
        p, c, r = int(pt[idx]), k[idx], rc[idx]
        dec = np.isin(c, list(decided))
        if p in decided:
            rs = np.unique(r[c == p])
            out[idx] = rs[0] if rs.size == 1 else reason_value(agree_)
        elif np.unique(c[dec]).size > 1:
            out[idx] = reason_value(disagree)
        else:
            cand = [i for i in np.flatnonzero(~dec) if c[i] >= 0] or \
                   [i for i in np.flatnonzero(~dec) if r[i] not in nothing]
            if cand:
                out[idx] = r[cand[0]]
            elif p >= 0 and (~dec).any():
                out[idx] = r[int(np.flatnonzero(~dec)[0])]
    return out


#: Decided codes of each label, and its undetermined code.
DECIDED = {"phase": ((0, 1, 2), PHASE_UNDETERMINED), "percolated": ((0, 1), PERCOLATION_UNDETERMINED),
           "kthny": ((0, 1, 2), KTHNY_UNDETERMINED)}
