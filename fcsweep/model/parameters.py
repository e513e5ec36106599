"""The model parameters, declared once.

Every parameter that determines a run is one :class:`Parameter` row of :data:`PARAMETERS`:
its type, default, allowed range, units and names.  From this table come the config
defaults and range checks (:mod:`fcsweep.config`), the defaults and checks of
:class:`fcsweep.simulation.SimParams`, the NetCDF attributes of swept coordinates
(:mod:`fcsweep.results.aggregate`), the JSON Schema editors read (``fcsweep schema``)
and the parameter table of configs/README.md (:func:`markdown_table`, checked by the
tests).  What involves several parameters at once (N = n*n with n even, K > 2M, the
tension limit of dt, the step bounds of v0*dt and Dr*dt, what ``core_exponent`` needs) is
checked where it is computed (:mod:`fcsweep.model.shape`, :func:`core_exponent_problem`,
:func:`fcsweep.config.check_runnable`).

Lengths are in units of R0, times in units of tau = R0 / (mu F) (docs/model.md); both
are reduced, so the CF ``units`` written to NetCDF are "1" for numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from fcsweep.model.confinement import BOUNDARIES
from fcsweep.model.integrators import DEFAULT_INTEGRATOR, INTEGRATORS, core_exponent_problem  # noqa: F401
from fcsweep.model.lattice import lattice_side
from fcsweep.model.rates import QUADRATURES
from fcsweep.model.sizes import SIZE_DISTRIBUTIONS

__all__ = ["Parameter", "PARAMETERS", "DEFAULTS", "INT_PARAMS", "STR_PARAMS", "RANGES", "ID_OMITS_DEFAULT",
           "INITIAL_STATES", "markdown_table", "core_exponent_problem", "value_problem",
           "N_RULE", "MODES_RULE", "CONTOUR_POINTS_RULE"]

#: The initial states a run may start from (the ``initial`` parameter, docs/model.md).
INITIAL_STATES = ("lattice", "disordered", "coexistence")

#: The physical bounds a parameter may have, checked before its range: name -> (test,
#: how the config error reads it, how SimParams' error reads it).
SIGNS = {
    ">= 0": (lambda x: x >= 0, "be >= 0", ">= 0"),
    "> 0": (lambda x: x > 0, "be > 0", "> 0"),
    "in (0, 1)": (lambda x: 0 < x < 1, "lie in (0, 1)", "in (0, 1)"),
}


@dataclass(frozen=True)
class Parameter:
    """One model parameter.

    Attributes
    ----------
    name : str
        Config key and :class:`~fcsweep.simulation.SimParams` field.
    type : type
        ``int``, ``float`` or ``str``.
    default : object
        Default value; ``None``: every sweep must give it (in ``model`` or ``grid``).
    range : tuple of float, optional
        Closed bounds ``(lo, hi)`` of a number (``hi`` open when ``upper_open``); the
        lower bounds of density and dt catch underflowed values (1e-320).
    sign : str
        Physical bound checked first, a key of :data:`SIGNS` ("" for none).
    choices : tuple of str
        Allowed values of a string parameter.
    unit : str
        Unit in the model's reduced units (R0, tau), for the docs.
    long_name : str
        CF long name of the swept coordinate in the NetCDF dataset.
    doc : str
        One line for editors (the JSON Schema description).
    meaning, allowed, default_doc : str
        The cells of configs/README.md's parameter table (``default_doc``: when the
        default needs words).
    id_omits_default : bool
        Left out of the run id (:func:`fcsweep.config.run_id_of`) when it has its
        default value: a parameter added after sweeps were run keeps their ids and seeds.
    """

    name: str
    type: type
    default: Any
    long_name: str
    doc: str
    meaning: str
    allowed: str
    range: tuple[float, float] | None = None
    upper_open: bool = False
    sign: str = ""
    choices: tuple[str, ...] = ()
    unit: str = "1"
    default_doc: str = ""
    id_omits_default: bool = False

    @property
    def units(self) -> str:
        """CF units attribute: "1" for numbers (reduced units), "" for strings."""
        return "" if self.type is str else "1"

    def sign_ok(self, value) -> bool:
        """Whether ``value`` satisfies the physical bound (:attr:`sign`)."""
        return not self.sign or SIGNS[self.sign][0](value)

    def in_range(self, value) -> bool:
        """Whether a number lies in :attr:`range`."""
        lo, hi = self.range
        return lo <= value and (value < hi if self.upper_open else value <= hi)

    def range_text(self) -> str:
        """The range as the config errors write it: ``allowed 1e-06 <= dt <= 1``."""
        lo, hi = self.range
        return f"allowed {lo:g} <= {self.name} {'<' if self.upper_open else '<='} {hi:g}"


#: The rules of the integer parameters that are more than a range, in the one wording the
#: config messages (``allowed ...``), the JSON Schema descriptions and configs/README.md's
#: table use.
N_RULE = "N = n*n with n even, 4 <= N <= 1000000"
MODES_RULE = "0 (rigid discs) or 2..32"
CONTOUR_POINTS_RULE = "8 <= contour_points <= 4096 and > 2 modes (fewer alias mode M)"

#: The model parameters, in the order run parameters are stored.
PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    Parameter("N", int, None, "number of cells",
              f"number of cells, an n x n hexagonal lattice: {N_RULE}", "number of cells, an n × n hexagonal lattice",
              N_RULE, range=(4, 10**6), unit="cells"),
    Parameter("eta", float, None, "membrane tension eta", "membrane tension",
              "membrane tension η", "0 … 10³", range=(0.0, 1e3), sign=">= 0", unit="F"),
    Parameter("v0", float, None, "self-propulsion speed v0 (R0 per time unit)",
              "self-propulsion speed (v0*dt within the step bound)", "self-propulsion speed",
              "0 … 10³, and v0·dt within the step bound below", range=(0.0, 1e3), sign=">= 0", unit="R0/τ"),
    Parameter("Dr", float, 0.01, "rotational diffusion D_r (per time unit)", "rotational diffusion (Dr*dt <= 0.1)",
              "rotational diffusion", "0 … 10³, and D_r·dt ≤ 0.1", range=(0.0, 1e3), sign=">= 0", unit="1/τ"),
    Parameter("density", float, 0.95, "area fraction N pi R0^2 / (Lx Ly)", "area fraction",
              "area fraction ρ", "10⁻⁶ ≤ ρ < 1", range=(1e-6, 1.0), upper_open=True, sign="in (0, 1)"),
    Parameter("dt", float, 5e-3, "Euler-Maruyama time step (time units)",
              "time step (also below the tension limit 1.5/lambda_M)", "time step",
              "10⁻⁶ ≤ dt ≤ 1 and ≤ 1.5/λ_M, λ_M = π μ_shape η R0 (M² − 1), at every grid point (the explicit "
              "step amplifies the stiffest shape mode above 2/λ_M; η = 0.1: ≤ 0.136, η = 1: ≤ 0.0136; no limit "
              "for `modes: 0`)", range=(1e-6, 1.0), sign="> 0", unit="τ"),
    Parameter("contour_points", int, 40, "contour quadrature points K",
              f"contour quadrature points K: {CONTOUR_POINTS_RULE}", "contour quadrature points K",
              CONTOUR_POINTS_RULE, range=(8, 4096), unit="points"),
    Parameter("modes", int, 6, "highest Fourier mode M", f"highest Fourier mode M: {MODES_RULE}",
              "highest Fourier mode M", MODES_RULE, range=(0, 32)),
    Parameter("quadrature", str, "arc", "contact quadrature rule", "contact quadrature (binary: the paper's)",
              "contact quadrature", "`binary` (paper), `linear`, `arc`; not sweepable with `modes: 0` (no effect)",
              choices=tuple(QUADRATURES), unit="",
              default_doc="`arc` (see the speed-against-error study; `binary` reproduces the paper)"),
    Parameter("R0", float, 1.0, "radius of the circle of equal area (length unit)",
              "radius of the circle of equal area", "radius of the circle of equal area", "10⁻³ … 10³",
              range=(1e-3, 1e3), sign="> 0", unit="length unit"),
    Parameter("mu_theta", float, 1.0, "mobility of the polarity angle", "mobility of the polarity angle",
              "mobility of θ", "0 … 10³", range=(0.0, 1e3), sign=">= 0", unit="1/(F R0 τ)"),
    Parameter("mu_shape", float, 1.0, "mobility of the shape modes", "mobility of the shape modes",
              "mobility of the shape modes", "0 … 10³", range=(0.0, 1e3), sign=">= 0", unit="1/(F R0 τ)"),
    Parameter("integrator", str, DEFAULT_INTEGRATOR, "time integrator of the contact forces",
              "time step scheme (euler: the paper's)", "time step scheme",
              "`euler` (the paper's explicit Euler–Maruyama), `contact-implicit` (each contact's normal "
              "relaxation implicit: contacts do not chatter; `fcsweep.model.integrators`), `contact-jacobi` (the "
              "same with each contact's approach rate from the other forces, two Jacobi sweeps per step; needs "
              "`quadrature: arc` and `modes` ≥ 2, refused otherwise). Part of the run id only when not `euler`, "
              "so ids of existing sweeps do not change", choices=tuple(INTEGRATORS), unit="", id_omits_default=True),
    Parameter("initial", str, "lattice", "initial state of the run",
              "initial state: lattice (hexagonal, default), disordered (isotropic, relaxed) or coexistence (a "
              "lattice slab in half the box, the disordered packing in the rest)", "initial state",
              "`lattice` (the n × n hexagonal lattice, circular cells), `disordered` (random centres in the same "
              "box, relaxed at v0 = 0: an isotropic start, docs/model.md), `coexistence` (half the box's rows on "
              "the lattice, the other half the disordered packing, two flat interfaces; N ≥ 64). Sweep "
              "`lattice` and `disordered` to bracket a label from both sides; the coexistence start decides it "
              "from the crystal's growth. Part of the run id only when not `lattice`, so ids of existing sweeps "
              "do not change",
              choices=INITIAL_STATES, unit="", id_omits_default=True),
    Parameter("adhesion", float, 0.0, "adhesion strength gamma (energy per adhered contour length)",
              "adhesion strength: energy per contour length within adhesion_range of another cell (0: off)",
              "adhesion strength γ: energy per unit of contour length lying inside or within `adhesion_range` of "
              "another cell (docs/model.md, Adhesion); same units as η",
              "0 … 10³ (0: off, today's model bit for bit). Part of the run id only when not 0, so ids of "
              "existing sweeps do not change", range=(0.0, 1e3), sign=">= 0", unit="F",
              id_omits_default=True),
    Parameter("adhesion_range", float, 0.1, "adhesion range delta (R0)",
              "range of the adhesion well outside a contact, in R0",
              "range δ of the adhesion well: a contour point adheres fully inside another cell and with a smooth "
              "weight falling to 0 at a radial gap δ outside it",
              "10⁻³ ≤ δ ≤ 0.5 (narrower wells are too stiff for any dt). No effect when `adhesion` is 0; part "
              "of the run id only when not 0.1", range=(1e-3, 0.5), sign="> 0", unit="R0",
              id_omits_default=True),
    Parameter("core_exponent", float, 1.0, "exponent p of the overlap energy sum A_ij^p",
              "exponent p of the overlap-area energy sum A_ij^p (1: the paper's; > 1 a harder core)",
              "exponent p of the overlap energy Σ A_ij^p (harder core)",
              "1 … 4; p ≠ 1 needs `quadrature: arc` (or `modes: 0`) and `integrator: euler`, refused otherwise. "
              "Part of the run id only when not 1, so ids of existing sweeps do not change",
              range=(1.0, 4.0), sign="> 0", id_omits_default=True),
    Parameter("size_distribution", str, "monodisperse", "distribution of the cell radii R0_i",
              "cell radii: monodisperse (default), bidisperse, lognormal or gaussian (truncated)",
              "distribution of the cell radii R0,i (mean R0)",
              "`monodisperse` (every R0,i = R0), `bidisperse` (`size_ratio`, `size_fraction`), `lognormal`, "
              "`gaussian` (relative width `size_width`, truncated at 2 widths); drawn from the seed through a "
              "stream of their own and scaled to mean R0; needs `initial: disordered` and `integrator: euler` "
              "(refused otherwise). Part of the run id only when not `monodisperse`",
              choices=SIZE_DISTRIBUTIONS, unit="", id_omits_default=True),
    Parameter("size_ratio", float, 1.4, "bidisperse radius ratio large/small",
              "bidisperse: radius of the large cells / radius of the small ones", "bidisperse radius ratio",
              "1 … 3 (only with `size_distribution: bidisperse`). Part of the run id only when not 1.4",
              range=(1.0, 3.0), sign="> 0", id_omits_default=True),
    Parameter("size_fraction", float, 0.5, "bidisperse fraction of small cells",
              "bidisperse: fraction of small cells", "bidisperse fraction of small cells",
              "0 … 1 (only with `size_distribution: bidisperse`). Part of the run id only when not 0.5",
              range=(0.0, 1.0), sign=">= 0", id_omits_default=True),
    Parameter("size_width", float, 0.1, "relative width of the lognormal/gaussian radii",
              "lognormal, gaussian: relative width of the radii (std / mean)", "relative width of the radii",
              "0 … 0.3 (only with `size_distribution: lognormal` or `gaussian`). Part of the run id only when "
              "not 0.1", range=(0.0, 0.3), sign=">= 0", id_omits_default=True),
    Parameter("boundary", str, "periodic", "boundary of the cells' domain",
              "boundary: periodic box (default), circular well, or channel (periodic along x, walls in y)",
              "boundary of the domain",
              "`periodic` (the box), `well` (a circular wall), `channel` (walls at two y, periodic along x); the "
              "wall's energy is the area of a cell beyond it, as another cell's overlap (docs/model.md, "
              "Confinement); needs `initial: disordered` and `integrator: euler`. Part of the run id only when not "
              "`periodic`", choices=BOUNDARIES, unit="", id_omits_default=True),
    Parameter("boundary_size", float, 0.0, "well radius or channel width (R0; 0: from N and density)",
              "well radius or channel width in R0 (0: from N and density)",
              "the well's radius R_w or the channel's width W",
              "0 … 10⁴ (0: the well's radius or the channel's width follows from N and `density`; a well of given "
              "radius holds its N cells at area fraction N R0²/R_w², and `density` is not used). Only with "
              "`boundary` `well` or `channel`; part of the run id only when not 0", range=(0.0, 1e4), sign=">= 0",
              unit="R0", id_omits_default=True),
)}

#: name -> default (``None``: must be given).
DEFAULTS: dict[str, Any] = {name: p.default for name, p in PARAMETERS.items()}
#: Integer parameters.
INT_PARAMS = tuple(name for name, p in PARAMETERS.items() if p.type is int)
#: String parameters and their allowed values.
STR_PARAMS = {name: p.choices for name, p in PARAMETERS.items() if p.type is str}
#: Parameters left out of the run id at their default: name -> default.
ID_OMITS_DEFAULT: dict[str, Any] = {name: p.default for name, p in PARAMETERS.items() if p.id_omits_default}
#: Bounds of the numeric parameters.
RANGES: dict[str, tuple[float, float]] = {name: p.range for name, p in PARAMETERS.items() if p.range}


def value_problem(name: str, value, key: str | None = None, shown: str | None = None) -> str:
    """Why ``value`` cannot be parameter ``name`` ("" if it can): the row's choices, its
    physical bound (:attr:`Parameter.sign`), its range and the rules of the integer
    parameters (:data:`N_RULE`, :data:`MODES_RULE`, :data:`CONTOUR_POINTS_RULE`).

    The one check of a single value, called by the config (:mod:`fcsweep.config`, after it
    has read the value's type) and by :class:`fcsweep.simulation.SimParams`; ``key`` is how
    the message names the value (``model.dt`` in a config, the name by default), ``shown``
    how it writes the value (as the user wrote it; ``repr`` by default).
    """
    key = key or name
    shown = repr(value) if shown is None else shown
    p = PARAMETERS[name]
    if p.type is str:
        return "" if value in p.choices else f"{key} = {shown} is not allowed; choose one of {list(p.choices)}"
    lo, hi = p.range
    if name == "modes":
        return "" if value == 0 or 2 <= value <= hi else f"{key} = {shown} is not allowed; modes is {MODES_RULE}"
    if p.type is int:
        if not lo <= value <= hi:
            return f"{key} = {shown} is out of range; allowed {lo:g} <= {name} <= {hi:g}"
        if name == "N":
            try:
                lattice_side(value)
            except ValueError as exc:
                return f"{key} = {shown}: {exc}"
        return ""
    if not math.isfinite(value):
        return f"{key} = {shown} must be a finite number; {p.range_text()}"
    if not p.sign_ok(value):
        return f"{key} = {shown} is out of range; {name} must {SIGNS[p.sign][1]}"
    return "" if p.in_range(value) else f"{key} = {shown} is out of range; {p.range_text()}"


def _default_cell(p: Parameter) -> str:
    if p.default_doc:
        return p.default_doc
    if p.default is None:
        return "—"
    if p.type is str:
        return f"`{p.default}`"
    return repr(p.default) if p.type is float and not (0 < abs(p.default) < 1e-2) else f"{p.default:g}"


def markdown_table() -> str:
    """The parameter table of configs/README.md (key, meaning, unit, allowed, default).

    Returns
    -------
    str
        Markdown, one row per parameter, ending with a newline.
    """
    rows = ["| key | meaning | unit | allowed | default |", "|---|---|---|---|---|"]
    for p in PARAMETERS.values():
        unit = p.unit if p.unit not in ("", "1") else "–"
        rows.append(f"| `{p.name}` | {p.meaning} | {unit} | {p.allowed} | {_default_cell(p)} |")
    return "\n".join(rows) + "\n"

