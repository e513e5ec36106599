"""Phase and percolation labels: integer codes with CF flag attributes, and their confidence.

solid       if D_eff < 1e-3;
soft-fluid  otherwise, if <q> > 3.81;
fluid       otherwise.
percolated  if rho_d > 1/2.
Unknown (-1) wherever an input is NaN.

With errors (:func:`classify_phase`, :func:`classify_percolation`) every observable is
taken as Gaussian about its estimate with its 1-sigma error, so that

    P(solid) = Phi((1e-3 - D_eff) / D_eff_err),
    P(soft fluid) = (1 - P(solid)) Phi((<q> - 3.81) / q_err),
    P(fluid) = (1 - P(solid)) (1 - Phi((<q> - 3.81) / q_err)),
    P(percolated) = Phi((rho_d - 1/2) / rho_d_err),

and the label is the most probable one when its probability reaches ``min_confidence``
(default 0.95, the config's ``analysis.label_confidence``), else *undetermined* (code 3
for the phase, 2 for percolation). The confidence reported is the probability of the
most probable label; the reason says what decided.

The phase rule is one function, :func:`phase_label`, for a run (its stored scalars) and
for a grid point (its replicate-combined scalars, :mod:`fcsweep.analysis.points`), on a
:class:`PhaseEvidence` built by :func:`phase_evidence`. Fluidity can be shown in a
finite window, solidity only bounded, so the evidence differs by side: where the cells
left their cages (``P(broken) >= min_confidence``, :mod:`fcsweep.analysis.cage`) the
cage-relative MSD past the breaking gives D_eff in its diffusive regime
(``D_eff_cr_late``), which decides solid against not solid with its error, and <q>
fluid against soft fluid; without broken cages only *solid* can be decided, from a
trustworthy ``D_eff_cr`` (:func:`solid_test_estimate`) with P(solid) (1 - P(broken)) >=
``min_confidence``; otherwise the label is undetermined ("a longer run decides").
:func:`classify_phase` without cage evidence is the plain D_eff test.

Every :class:`Label` carries beside its reason text a ``reason_code``, one of the declared
:data:`fcsweep.analysis.reasons.REASONS` (``too_short``, ``near_d_threshold``, ...).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from fcsweep.analysis.cage import broken_probability
from fcsweep.analysis.diffusion import D_EFF_SOLID
from fcsweep.analysis.reasons import REASON_BY_NAME
from fcsweep.model.settings import LABEL_CONFIDENCE, PERCOLATION_THRESHOLD
from fcsweep.model.shape import Q_STAR

#: Percolation threshold of the defect fraction (site percolation on a triangular lattice):
#: the default of the analysis setting ``percolation_threshold``.
RHO_D_PERCOLATION = PERCOLATION_THRESHOLD

PHASE_UNKNOWN, PHASE_SOLID, PHASE_FLUID, PHASE_SOFT_FLUID, PHASE_UNDETERMINED = -1, 0, 1, 2, 3
#: Codes and CF ``flag_meanings`` (blank-separated words) of the phase label.
PHASE_FLAGS = {PHASE_UNKNOWN: "unknown", PHASE_SOLID: "solid", PHASE_FLUID: "fluid",
               PHASE_SOFT_FLUID: "soft_fluid", PHASE_UNDETERMINED: "undetermined"}
PERCOLATION_UNDETERMINED = 2
#: Codes of the percolation label.
PERCOLATION_FLAGS = {-1: "unknown", 0: "not_percolated", 1: "percolated",
                     PERCOLATION_UNDETERMINED: "undetermined"}
#: Why a label is undetermined where the equilibration cut reached its limit.
NOT_STATIONARY = ("the equilibration cut reached its limit (half the frames after the transient): <q> or rho_d "
                  "still drifts there, so no label is decided on this window; a longer run decides")
#: Default probability a label needs (the analysis setting ``label_confidence``).
MIN_CONFIDENCE = LABEL_CONFIDENCE


def phase_code(D_eff, q_mean, *, d_solid: float = D_EFF_SOLID, q_star: float = Q_STAR):
    """Integer phase code(s) from D_eff and <q> (arrays broadcast).

    Returns
    -------
    ndarray of int8
        0 solid, 1 fluid, 2 soft-fluid, -1 unknown (D_eff NaN, or <q> NaN when fluid).
    """
    D = np.asarray(D_eff, dtype=float)
    q = np.asarray(q_mean, dtype=float)
    D, q = np.broadcast_arrays(D, q)
    out = np.full(D.shape, PHASE_UNKNOWN, dtype=np.int8)
    solid = np.isfinite(D) & (D < d_solid)
    moving = np.isfinite(D) & (D >= d_solid) & np.isfinite(q)
    out[solid] = PHASE_SOLID
    out[moving & (q > q_star)] = PHASE_SOFT_FLUID
    out[moving & ~(q > q_star)] = PHASE_FLUID
    return out


def phase_name(code: int) -> str:
    """Human-readable name of a phase code ('soft-fluid' with a hyphen)."""
    return PHASE_FLAGS.get(int(code), "unknown").replace("_", "-")


@dataclass(frozen=True)
class Label:
    """A label with its confidence: ``code`` (see the flag tables), ``confidence``
    (probability of the most probable label, NaN when unknown), ``reason`` (free text) and
    ``reason_code`` (a name of :data:`fcsweep.analysis.reasons.REASONS`: what decided, or
    why nothing did)."""

    code: int
    confidence: float
    reason: str
    reason_code: str

    def __post_init__(self):
        if self.reason_code not in REASON_BY_NAME:
            raise ValueError(f"undeclared reason code {self.reason_code!r}")


def p_above(x: float, err: float, threshold: float) -> float:
    """P(true value > threshold) for a Gaussian estimate ``x +- err`` (err 0: a step)."""
    if err > 0:
        return float(ndtr((x - threshold) / err))
    return 1.0 if x > threshold else (0.5 if x == threshold else 0.0)


def phase_probabilities(D_eff, D_eff_err, q_mean, q_mean_err, *, d_solid: float = D_EFF_SOLID,
                        q_star: float = Q_STAR) -> dict:
    """Probabilities of solid, fluid and soft fluid from Gaussian estimates (see module doc).

    Returns
    -------
    dict
        phase code -> probability; NaN errors give NaN probabilities.
    """
    p_solid = 1.0 - p_above(float(D_eff), float(D_eff_err), d_solid)
    p_soft = p_above(float(q_mean), float(q_mean_err), q_star)
    if not np.isfinite(q_mean):
        p_soft = float("nan")
    return {PHASE_SOLID: p_solid, PHASE_SOFT_FLUID: (1 - p_solid) * p_soft,
            PHASE_FLUID: (1 - p_solid) * (1 - p_soft)}


def _fmt(x: float, e: float) -> str:
    return f"{x:.3g} +- {e:.2g}"


def classify_phase(D_eff, D_eff_err, q_mean, q_mean_err, *, diffusion_ok: bool = True,
                   diffusion_note: str = "", diffusion_code: str = "not_diffusive",
                   cage_broken: float | None = None, cage_note: str = "",
                   D_late: float = float("nan"), D_late_err: float = float("nan"),
                   min_confidence: float = MIN_CONFIDENCE, d_solid: float = D_EFF_SOLID,
                   q_star: float = Q_STAR) -> Label:
    """Phase label of one run or point with its confidence and the reason.

    Parameters
    ----------
    D_eff, D_eff_err, q_mean, q_mean_err : float
        Estimates and 1-sigma errors.
    diffusion_ok : bool
        False when the D_eff estimate cannot be trusted (run too short, MSD not
        diffusive): D_eff then decides nothing, ``diffusion_note`` is the reason and
        ``diffusion_code`` its reason code (``not_diffusive`` or ``too_short``).
    cage_broken : float, optional
        Probability that the cells left their cages within the window
        (:mod:`fcsweep.analysis.cage`; NaN: no cage test). Given, this is the phase rule
        :func:`phase_label` with ``D_eff`` as the solid test and ``D_late``,
        ``D_late_err`` as D_eff_cr_late. Not given (None), D_eff decides both sides (a
        plain D_eff test, used where no cage test exists).
    min_confidence : float
        Probability the most probable label needs.

    Returns
    -------
    Label
    """
    D, De, q, qe = (float(v) for v in (D_eff, D_eff_err, q_mean, q_mean_err))
    if cage_broken is not None:
        ev = PhaseEvidence(D, De, bool(diffusion_ok), diffusion_note, float(cage_broken), cage_note,
                           float(D_late), float(D_late_err), q, qe, diffusion_code)
        return phase_label(ev, min_confidence=min_confidence, d_solid=d_solid, q_star=q_star)
    if not np.isfinite(D):
        return Label(PHASE_UNKNOWN, float("nan"), "D_eff not available", "not_available")
    if not np.isfinite(De):
        return Label(PHASE_UNDETERMINED, float("nan"), "D_eff has no error estimate", "no_error")
    if np.isfinite(q) and np.isfinite(qe):
        p = phase_probabilities(D, De, q, qe, d_solid=d_solid, q_star=q_star)
    else:
        p = {PHASE_SOLID: 1.0 - p_above(D, De, d_solid)}
        if p[PHASE_SOLID] < min_confidence:  # fluid or soft fluid: <q> must decide
            if not np.isfinite(q):
                return Label(PHASE_UNKNOWN, float("nan"), "<q> not available", "not_available")
            return Label(PHASE_UNDETERMINED, float("nan"), "<q> has no error estimate", "no_error")
    best = max(p, key=lambda k: p[k])
    conf = float(p[best])
    if not diffusion_ok:
        return Label(PHASE_UNDETERMINED, conf, diffusion_note or "D_eff estimate not trustworthy", diffusion_code)
    if conf < min_confidence:
        if min(p[PHASE_SOLID], 1 - p[PHASE_SOLID]) >= 1 - min_confidence:
            why, rc = f"D_eff = {_fmt(D, De)} too close to the solid threshold {d_solid:g}", "near_d_threshold"
        else:
            why, rc = f"<q> = {_fmt(q, qe)} too close to {q_star:g}", "near_q_star"
        return Label(PHASE_UNDETERMINED, conf, f"{why} (P = {conf:.2f} < {min_confidence:.2f})", rc)
    return Label(int(best), conf, f"P({phase_name(best)}) = {conf:.3f}", "decided_d_eff")


@dataclass(frozen=True)
class PhaseEvidence:
    """What the phase rule (:func:`phase_label`) reads, for a run or a grid point.

    Attributes
    ----------
    D_solid, D_solid_err : float
        The solid test's D_eff and error (:func:`solid_test_estimate`).
    solid_trusted : bool
        Whether that estimate may decide "solid" (run long enough, slope settled).
    trust_note : str
        Why not, when it is not.
    p_broken : float
        Probability that the cells left their cages (:mod:`fcsweep.analysis.cage`); NaN:
        no cage test.
    cage_note : str
        What the cage test saw.
    D_late, D_late_err : float
        ``D_eff_cr_late``: D_eff from the cage-relative MSD past the cage-breaking lag
        (neighbour-corrected); NaN where the cages did not break clearly.
    q, q_err : float
        ``<q>`` and its error.
    trust_code : str
        Reason code of ``trust_note`` (``too_short`` or ``not_diffusive``).
    D_solid_name : str
        Which estimate ``D_solid`` is (``D_eff_cr``, ``D_eff_long`` or ``D_eff``): the
        reasons name it.
    stationary : bool
        False where the equilibration cut reached its limit (``equilibration_at_limit``):
        nothing is decided on that window (:data:`NOT_STATIONARY`).
    bias : tuple of float
        The measured systematic offsets of the run's contour rule and step
        (``q_bias_low``, ``q_bias_high``, ``d_bias_low``, ``d_bias_high``,
        :func:`fcsweep.model.systematics.rule_bias`; zeros where not stored).
    p_relaxed : float
        ``P(F_s_bound < 1/e)``: the probability that the cage-relative ``F_s(2 pi / a)``
        decayed by ``relaxation_lag``, faster than any state at ``D_eff = 1e-3`` can
        (:meth:`fcsweep.analysis.cage.CageBreaking.relaxation_lag`); NaN where that lag is
        beyond the window.
    """

    D_solid: float
    D_solid_err: float
    solid_trusted: bool
    trust_note: str
    p_broken: float
    cage_note: str
    D_late: float
    D_late_err: float
    q: float
    q_err: float
    trust_code: str = "not_diffusive"
    D_solid_name: str = "D_eff"
    stationary: bool = True
    bias: tuple = (0.0, 0.0, 0.0, 0.0)
    p_relaxed: float = float("nan")


def solid_test_name(sc: dict) -> str:
    """The name of the estimate :func:`solid_test_estimate` takes from ``sc``."""
    if np.isfinite(sc.get("D_eff_cr", np.nan)) and np.isfinite(sc.get("D_eff_cr_err", np.nan)):
        return "D_eff_cr"
    if sc.get("n_time_blocks", 1) >= 2 and np.isfinite(sc.get("D_eff_long", np.nan)) \
            and np.isfinite(sc.get("D_eff_long_err", np.nan)):
        return "D_eff_long"
    return "D_eff"


def solid_test_estimate(sc: dict) -> tuple[float, float]:
    """D_eff and error on which the phase rule tests "solid" where the cages did not break.

    The cage-relative D_eff (``D_eff_cr``, a quarter of the slope of the cage-relative MSD
    over the last three quarters of the window) where it exists: in a fluid it tends to
    D_eff (times 1 + 1/n for n ~ 6 neighbours), in a solid to 0, without the
    long-wavelength fluctuations that keep the plain MSD of a 2-D crystal rising long after
    its cages have formed (measured at N = 1024, eta = 0.1, v0 = 0.01-0.03: plain D_eff
    1.4-2.3e-3 over 800 time units against cage-relative MSDs of 2e-4 to 2e-3 a^2;
    docs/statistics.md). Otherwise the plain D_eff over the longest window: the whole
    window as one block (``D_eff_long`` when there are several blocks) sees a slow cage
    plateau that short blocks miss; else ``D_eff``.
    """
    name = solid_test_name(sc)
    return float(sc.get(name, np.nan)), float(sc.get(f"{name}_err", np.nan))


def cage_evidence(sc: dict) -> tuple[float, str]:
    """Probability that the cells left their cages, as the phase rule takes it, and a note.

    ``P(cage_msd_ratio > 1)`` from the ratio and its error (so that a grid point's
    replicate-combined ratio gives its own probability); NaN where the cage test could
    not be made or has no error. ``cage_d_eff_bound`` is not read: it no longer gates anything.
    """
    ratio, err = float(sc.get("cage_msd_ratio", np.nan)), float(sc.get("cage_msd_ratio_err", np.nan))
    lag = float(sc.get("cage_lag", np.nan))
    if not np.isfinite(ratio):
        return float("nan"), "cage test not possible (too few frames or cells)"
    p = broken_probability(ratio, err) if np.isfinite(err) else float("nan")
    where = f"cage-relative MSD {ratio:.3g} +- {err:.2g} a^2 over {lag:.4g} time units"
    if not np.isfinite(p):
        return float("nan"), f"{where}: no error"
    if p >= 0.5:
        return float(p), where
    return float(p), f"no cage broken within the window ({where})"


def _flag(sc: dict, name: str) -> bool:
    v = float(sc.get(name, np.nan))
    return bool(np.isfinite(v) and v >= 0.5)


#: F_s(2 pi / a) below which the structure relaxed (the definition of tau_alpha).
F_S_RELAXED = float(np.exp(-1.0))


def relaxed_probability(sc: dict) -> float:
    """``P(F_s_bound < 1/e)`` from ``F_s_bound`` and its error (NaN where not measured)."""
    f, e = float(sc.get("F_s_bound", np.nan)), float(sc.get("F_s_bound_err", np.nan))
    if not (np.isfinite(f) and np.isfinite(e)):
        return float("nan")
    return 1.0 - p_above(f, e, F_S_RELAXED)


def phase_evidence(sc: dict, note: str | None = None) -> PhaseEvidence:
    """The evidence of the phase rule from stored scalars (a run's, or a point's
    replicate-combined ones with its flags the least favourable replicate's).

    ``note`` (the pipeline's detailed wording) replaces the generic reason why the solid
    test is not trusted; trust itself always comes from the flags: ``msd_long_enough``,
    and ``msd_diffusive`` where there is no cage-relative D_eff.
    """
    D, De = solid_test_estimate(sc)
    long_enough = _flag(sc, "msd_long_enough")
    has_cr = np.isfinite(sc.get("D_eff_cr", np.nan)) and np.isfinite(sc.get("D_eff_cr_err", np.nan))
    bounded = _flag(sc, "msd_bounded")  # a well or a channel: the whole-cell MSD cannot decide
    trusted = long_enough and (has_cr or (_flag(sc, "msd_diffusive") and not bounded))
    why = ""
    code = "not_diffusive" if long_enough else "too_short"
    if long_enough and bounded and not has_cr:
        code, note = "msd_bounded", ("confined run: the whole-cell MSD is bounded by the walls and no cage-relative "
                                     "D_eff_cr was measured (too few cells away from the walls), so D_eff is not "
                                     "trustworthy")
    if not trusted:
        why = note or ("run too short for D_eff (a time block shorter than min_block_persistence / Dr)"
                       if not long_enough else "MSD not diffusive within the run")
    p, cage_note = cage_evidence(sc)
    return PhaseEvidence(D, De, trusted, why, p, cage_note, float(sc.get("D_eff_cr_late", np.nan)),
                         float(sc.get("D_eff_cr_late_err", np.nan)), float(sc.get("q_mean", np.nan)),
                         float(sc.get("q_mean_err", np.nan)), code, solid_test_name(sc),
                         not _flag(sc, "equilibration_at_limit"),
                         tuple(float(np.nan_to_num(sc.get(k, 0.0), nan=0.0, posinf=np.inf, neginf=-np.inf))
                               for k in BIAS_KEYS), relaxed_probability(sc))


#: The scalars of the measured systematic offsets (:func:`fcsweep.model.systematics.rule_bias`).
BIAS_KEYS = ("q_bias_low", "q_bias_high", "d_bias_low", "d_bias_high")


def phase_label(ev: PhaseEvidence, *, min_confidence: float = MIN_CONFIDENCE, d_solid: float = D_EFF_SOLID,
                q_star: float = Q_STAR) -> Label:
    """The phase rule, for a run (its scalars) and a grid point (its replicate-combined ones).

    A decided label whose deciding estimate, corrected by any offset in the measured range of
    the run's contour rule and step (``ev.bias``), would lie on the other side of its
    threshold is undetermined, reason code ``rule_sensitive`` (:func:`rule_sensitivity`);
    the rest is :func:`phase_rule`.

    Returns
    -------
    Label
    """
    lab = phase_rule(ev, min_confidence=min_confidence, d_solid=d_solid, q_star=q_star)
    why = rule_sensitivity(lab, ev, d_solid=d_solid, q_star=q_star)
    return Label(PHASE_UNDETERMINED, float("nan"), why, "rule_sensitive") if why else lab


def rule_sensitivity(lab: Label, ev: PhaseEvidence, *, d_solid: float = D_EFF_SOLID, q_star: float = Q_STAR) -> str:
    """Why a decided phase label depends on the contour rule's or the step's systematic
    offset ("" if it does not): the deciding D (``D_eff_cr_late`` where the cages broke,
    else the solid test's) or ``<q>`` (fluid against soft fluid), corrected by the offsets'
    range (D measured = D (1 + d), <q> measured = <q> + q), straddles its threshold."""
    if lab.code not in (PHASE_SOLID, PHASE_FLUID, PHASE_SOFT_FLUID) or not any(ev.bias):
        return ""
    ql, qh, dl, dh = ev.bias
    if not np.isfinite(ev.bias).all():  # +-inf: not measured
        return ("the systematic offset of <q> and D at this dt was not measured (above 0.02): the label could "
                "depend on it; rerun at dt <= 0.02")
    broken = lab.reason_code == "decided_cages_broken"
    D, name = (ev.D_late, "D_eff_cr_late") if broken else (ev.D_solid, ev.D_solid_name)
    if lab.reason_code != "decided_relaxed" and np.isfinite(D) and dl > -1.0 and dh > -1.0:
        lo, hi = D / (1.0 + dh), D / (1.0 + dl)
        if lo < d_solid < hi:
            return (f"{name} = {D:.3g}, corrected by the measured offset of D for this contour rule and dt "
                    f"({dl:+.0%} .. {dh:+.0%}), lies between {lo:.3g} and {hi:.3g}, on both sides of {d_solid:g}")
    if lab.code != PHASE_SOLID and np.isfinite(ev.q):
        lo, hi = ev.q - qh, ev.q - ql
        if lo < q_star < hi:
            return (f"<q> = {ev.q:.4f}, corrected by the measured offset of <q> for this contour rule and dt "
                    f"({ql:+.3f} .. {qh:+.3f}), lies between {lo:.4f} and {hi:.4f}, on both sides of {q_star:g}; "
                    "the arc rule decides")
    return ""


def phase_rule(ev: PhaseEvidence, *, min_confidence: float = MIN_CONFIDENCE, d_solid: float = D_EFF_SOLID,
               q_star: float = Q_STAR) -> Label:
    """The phase rule on the evidence as measured (:func:`phase_label` adds the systematic
    offsets).

    With broken cages (``p_broken >= min_confidence``) ``D_late`` (D_eff_cr_late, the
    paper's D_eff measured in its diffusive regime) decides solid against not solid with
    its error, and ``<q>`` fluid against soft fluid; without enough lags past the
    breaking the label is undetermined. Without broken cages "solid" needs a trusted
    ``D_solid`` below ``d_solid`` with ``P(solid) (1 - p_broken) >= min_confidence``;
    anything else is undetermined (a longer run decides).

    Returns
    -------
    Label
    """
    if not ev.stationary:
        return Label(PHASE_UNDETERMINED, float("nan"), NOT_STATIONARY, "not_stationary")
    p_b, p_r = ev.p_broken, ev.p_relaxed
    relaxed = np.isfinite(p_r) and p_r >= min_confidence
    if np.isfinite(p_b) and p_b >= min_confidence:
        lab = _broken_label(ev, min_confidence, d_solid, q_star)
        # broken, but too few lags past the breaking for D_eff_cr_late: F_s may still decide
        return _relaxed_label(ev, min_confidence, q_star) if relaxed and lab.reason_code in (
            "few_late_lags", "no_error") else lab
    if relaxed:
        return _relaxed_label(ev, min_confidence, q_star)
    D, De, name = ev.D_solid, ev.D_solid_err, ev.D_solid_name
    d_known = ev.solid_trusted and np.isfinite(D) and np.isfinite(De)
    p_solid_d = 1.0 - p_above(D, De, d_solid) if d_known else float("nan")
    if d_known and p_solid_d >= min_confidence:
        conf = float(p_solid_d * (1.0 - p_b if np.isfinite(p_b) else 1.0) * (1.0 - p_r if np.isfinite(p_r) else 1.0))
        if conf < min_confidence:
            return Label(PHASE_UNDETERMINED, conf, f"{name} = {_fmt(D, De)} reads solid but the cages may be "
                                                   f"broken (P = {p_b:.2f}); a longer run decides",
                         "cages_may_be_broken")
        why = f"P(solid) = {conf:.3f}"
        return Label(PHASE_SOLID, conf, f"{why}; {ev.cage_note}" if ev.cage_note else why, "solid_cages_intact")
    conf = float(max(p_solid_d, 1.0 - p_solid_d)) if np.isfinite(p_solid_d) else float("nan")
    if not ev.solid_trusted:
        why, rc = ev.trust_note or "D_eff estimate not trustworthy", ev.trust_code
    elif not np.isfinite(D):
        return Label(PHASE_UNKNOWN, float("nan"), f"{name} not available", "not_available")
    elif not np.isfinite(De):
        why, rc = f"{name} has no error estimate", "no_error"
    elif p_solid_d <= 1.0 - min_confidence:
        why, rc = f"{name} = {_fmt(D, De)} reads fluid", "fluid_cages_intact"
    else:
        why = f"{name} = {_fmt(D, De)} too close to the solid threshold {d_solid:g} (P = {conf:.2f})"
        rc = "near_d_threshold"
    cage = ev.cage_note or "no evidence that the cells left their cages"
    return Label(PHASE_UNDETERMINED, conf, f"{why}; {cage}; a longer run decides", rc)


def _relaxed_label(ev: PhaseEvidence, min_confidence, q_star) -> Label:
    """:func:`phase_rule` where the cage-relative ``F_s`` decayed faster than a state at the
    solid threshold can (the cages not yet broken by ``a^2``): not solid, and ``<q>``
    decides fluid against soft fluid."""
    relaxed = (f"cage-relative F_s(2 pi / a) below 1/e by the lag a state at D_eff = 1e-3 would need at the "
               f"earliest (P = {ev.p_relaxed:.3f}): not solid")
    q, qe = ev.q, ev.q_err
    if not np.isfinite(q):
        return Label(PHASE_UNKNOWN, float("nan"), "<q> not available", "not_available")
    if not np.isfinite(qe):
        return Label(PHASE_UNDETERMINED, float("nan"), "<q> has no error estimate", "no_error")
    p_soft = p_above(q, qe, q_star)
    p = {PHASE_SOFT_FLUID: ev.p_relaxed * p_soft, PHASE_FLUID: ev.p_relaxed * (1.0 - p_soft)}
    best = max(p, key=lambda k: p[k])
    conf = float(p[best])
    if conf < min_confidence:
        return Label(PHASE_UNDETERMINED, conf, f"{relaxed}, but <q> = {_fmt(q, qe)} too close to {q_star:g} "
                                               f"(P = {conf:.2f} < {min_confidence:.2f})", "near_q_star")
    return Label(int(best), conf, f"{relaxed}; P({phase_name(best)}) = {conf:.3f}", "decided_relaxed")


def _broken_label(ev: PhaseEvidence, min_confidence, d_solid, q_star) -> Label:
    """:func:`phase_label` where the cages broke: ``D_late`` and ``<q>`` decide."""
    cages = f"cages broken (P = {ev.p_broken:.3f})"
    D, De, q, qe = ev.D_late, ev.D_late_err, ev.q, ev.q_err
    if not np.isfinite(D):
        return Label(PHASE_UNDETERMINED, float("nan"), f"{cages} but too few lags past the breaking for "
                                                       "D_eff_cr_late; a longer run decides", "few_late_lags")
    if not (np.isfinite(De) and De > 0):
        return Label(PHASE_UNDETERMINED, float("nan"), f"{cages} but D_eff_cr_late has no error estimate",
                     "no_error")
    p_solid = 1.0 - p_above(D, De, d_solid)
    late = f"D_eff_cr_late = {_fmt(D, De)}"
    if p_solid >= min_confidence:
        return Label(PHASE_SOLID, float(p_solid), f"{cages}; {late}: P(solid) = {p_solid:.3f}",
                     "decided_cages_broken")
    if p_solid > 1.0 - min_confidence:
        conf = float(max(p_solid, 1.0 - p_solid))
        return Label(PHASE_UNDETERMINED, conf, f"{cages}; {late} too close to the solid threshold {d_solid:g} "
                                               f"(P = {conf:.2f} < {min_confidence:.2f}); a longer run decides",
                     "near_d_threshold")
    if not np.isfinite(q):
        return Label(PHASE_UNKNOWN, float("nan"), "<q> not available", "not_available")
    if not np.isfinite(qe):
        return Label(PHASE_UNDETERMINED, float("nan"), "<q> has no error estimate", "no_error")
    p_soft = p_above(q, qe, q_star)
    p = {PHASE_SOFT_FLUID: (1.0 - p_solid) * p_soft, PHASE_FLUID: (1.0 - p_solid) * (1.0 - p_soft)}
    best = max(p, key=lambda k: p[k])
    conf = float(p[best])
    if conf < min_confidence:
        return Label(PHASE_UNDETERMINED, conf, f"{cages}; {late} but <q> = {_fmt(q, qe)} too close to "
                                               f"{q_star:g} (P = {conf:.2f} < {min_confidence:.2f})",
                     "near_q_star")
    return Label(int(best), conf, f"{cages}; {late}: P({phase_name(best)}) = {conf:.3f}", "decided_cages_broken")


#: What kind of solid a solid label is (``solid_kind``; -1 where the label is not solid).
SOLID_KIND_FLAGS = {-1: "not_solid", 0: "crystal", 1: "amorphous", 2: "undetermined"}
#: A solid is a crystal when its global |Psi6| is above PSI6_CRYSTAL (one orientation over the
#: box: a polycrystal's or a glass's grains average it down; the lattice solids of the
#: both-starts campaign read 0.90-0.97, the disordered-start solids 0.09-0.51) and its
#: Voronoi defect fraction below RHO_D_CRYSTAL (bound dislocation pairs only: 0-0.001 from
#: the lattice, 0.06-0.11 from the disordered start at the same points); amorphous otherwise.
PSI6_CRYSTAL, RHO_D_CRYSTAL = 0.7, 0.02


def solid_kind(phase_code, psi6, psi6_err, rho_d, rho_d_err, *,
               min_confidence: float = MIN_CONFIDENCE) -> tuple[int, float]:
    """Crystal or amorphous, for a solid label (:data:`SOLID_KIND_FLAGS`, with the
    probability of the kind given: P(crystal) = P(|Psi6| > PSI6_CRYSTAL) P(rho_d <
    RHO_D_CRYSTAL) with Gaussian errors); (-1, NaN) where the label is not solid, (2, P) where
    neither kind reaches ``min_confidence`` or an input is missing."""
    if int(phase_code) != PHASE_SOLID:
        return -1, float("nan")
    values = np.array([psi6, psi6_err, rho_d, rho_d_err], dtype=float)
    if not np.isfinite(values).all():
        return 2, float("nan")
    p_crystal = p_above(psi6, psi6_err, PSI6_CRYSTAL) * (1.0 - p_above(rho_d, rho_d_err, RHO_D_CRYSTAL))
    kind, p = (0, p_crystal) if p_crystal >= 0.5 else (1, 1.0 - p_crystal)
    return (kind if p >= min_confidence else 2), float(p)


def classify_percolation(rho_d, rho_d_err, *, min_confidence: float = MIN_CONFIDENCE,
                         threshold: float = RHO_D_PERCOLATION, stationary: bool = True) -> Label:
    """Percolation label of one run or point with its confidence and the reason
    (undetermined, :data:`NOT_STATIONARY`, where the window is not ``stationary``)."""
    r, e = float(rho_d), float(rho_d_err)
    if not stationary and np.isfinite(r):
        return Label(PERCOLATION_UNDETERMINED, float("nan"), NOT_STATIONARY, "not_stationary")
    if not np.isfinite(r):
        return Label(-1, float("nan"), "rho_d not available", "not_available")
    if not np.isfinite(e):
        return Label(PERCOLATION_UNDETERMINED, float("nan"), "rho_d has no error estimate", "no_error")
    p = p_above(r, e, threshold)
    conf = max(p, 1 - p)
    if conf < min_confidence:
        return Label(PERCOLATION_UNDETERMINED, conf,
                     f"rho_d = {_fmt(r, e)} too close to {threshold:g} (P = {conf:.2f} < {min_confidence:.2f})",
                     "near_rho_threshold")
    code = int(p >= 0.5)
    return Label(code, conf, f"P({PERCOLATION_FLAGS[code]}) = {conf:.3f}", "decided_rho_d")


def percolation_code(rho_d, *, threshold: float = RHO_D_PERCOLATION):
    """1 where rho_d > threshold, 0 where not, -1 where rho_d is NaN (int8 array)."""
    r = np.asarray(rho_d, dtype=float)
    out = np.full(r.shape, -1, dtype=np.int8)
    ok = np.isfinite(r)
    out[ok] = (r[ok] > threshold).astype(np.int8)
    return out


def flag_attrs(flags: dict) -> dict:
    """CF ``flag_values`` / ``flag_meanings`` attributes for an int8 code variable."""
    keys = sorted(flags)
    return {"flag_values": np.array(keys, dtype=np.int8),
            "flag_meanings": " ".join(flags[k] for k in keys)}


KTHNY_UNKNOWN, KTHNY_SOLID, KTHNY_HEXATIC, KTHNY_LIQUID, KTHNY_UNDETERMINED = -1, 0, 1, 2, 3
#: Codes and CF ``flag_meanings`` of the KTHNY label (:mod:`fcsweep.analysis.kthny`).
KTHNY_FLAGS = {KTHNY_UNKNOWN: "unknown", KTHNY_SOLID: "solid", KTHNY_HEXATIC: "hexatic", KTHNY_LIQUID: "liquid",
               KTHNY_UNDETERMINED: "undetermined"}


def kthny_name(code: int) -> str:
    """Word of a KTHNY label code ('solid', 'hexatic', 'liquid', 'undetermined', 'unknown')."""
    return KTHNY_FLAGS.get(int(code), "unknown")
