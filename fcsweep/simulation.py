"""State, parameters and the step loop of the Fourier contour cell model (no file I/O
beyond an explicit ``save``/``load`` of the full state).

>>> from fcsweep.simulation import Simulation
>>> sim = Simulation.from_lattice(N=64, eta=0.03, v0=0.06, Dr=0.1, seed=1)
>>> sim.advance(100)
>>> sim.state.pos.shape
(64, 2)
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import warnings
from dataclasses import dataclass

import numba
import numpy as np

from . import __version__
from .frames import Frames
from .io.atomic import atomic_write
from .kernels.records import P_DMAX
from .kernels.step import LIST_FULL, NONFINITE, OK, run_chunk
from .kernels.api import param_vector
from .kernels.workspace import quadrature_code, workspace_for
from .model.integrators import DEFAULT_INTEGRATOR, INTEGRATORS, contact_parameters, integrator_problem
from .model.confinement import boundary_problem, confinement_of
from .model.coexistence import coexistence_centres, coexistence_problem, coexistence_rng
from .model.disordered import random_centres, soft_disc_relax, start_rng
from .model.lattice import hexagonal_lattice, lattice_box
from .model.parameters import DEFAULTS, PARAMETERS, core_exponent_problem, value_problem
from .model.sizes import cell_radii, effective_radius, radius_bounds, size_problem
from .model.shape import (ADMISSIBLE_BOUND, PROJECTION_MARGIN, contour_points_problem, dt_problem, step_problem,
                          turn_problem)

__all__ = ["INTEGRATORS", "SimParams", "Simulation", "SimulationError", "State"]

#: Steps whose noise is drawn at once; any value gives the same trajectory.
CHUNK = 256
#: Fraction of cell-steps projected back onto the admissibility bound, within one chunk,
#: above which advance() warns: shapes pinned at the bound are a sign of too large a dt
#: (docs/model.md: at eta = 0.03, dt = 0.2 gives <q> = 4.5 instead of 3.7 while staying finite).
PINNED_WARNING = 0.25
#: Duration (time units) of the model's own relaxation at v0 = 0 that ends the
#: ``disordered`` start (docs/model.md).
RELAX_TIME = 20.0
#: Cells per thread below which extra threads cost more in synchronisation (three
#: parallel regions per step) than they save; results do not depend on the threads.
CELLS_PER_THREAD = 512


class SimulationError(RuntimeError):
    """The dynamics became non-finite or unstable; the message names a likely cause."""


@dataclass(frozen=True)
class SimParams:
    """Every parameter that determines a run (with ``seed``).

    Fields, defaults and single-value bounds are the rows of the parameter table
    :data:`fcsweep.model.parameters.PARAMETERS` (docs/model.md); ``Dr`` is not given in the
    paper (see docs/model.md).
    """

    N: int
    eta: float
    v0: float
    seed: int
    Dr: float = DEFAULTS["Dr"]
    density: float = DEFAULTS["density"]
    dt: float = DEFAULTS["dt"]
    contour_points: int = DEFAULTS["contour_points"]
    modes: int = DEFAULTS["modes"]
    quadrature: str = DEFAULTS["quadrature"]
    R0: float = DEFAULTS["R0"]
    mu_theta: float = DEFAULTS["mu_theta"]
    mu_shape: float = DEFAULTS["mu_shape"]
    integrator: str = DEFAULTS["integrator"]
    initial: str = DEFAULTS["initial"]
    adhesion: float = DEFAULTS["adhesion"]
    adhesion_range: float = DEFAULTS["adhesion_range"]
    core_exponent: float = DEFAULTS["core_exponent"]
    size_distribution: str = DEFAULTS["size_distribution"]
    size_ratio: float = DEFAULTS["size_ratio"]
    size_fraction: float = DEFAULTS["size_fraction"]
    size_width: float = DEFAULTS["size_width"]
    boundary: str = DEFAULTS["boundary"]
    boundary_size: float = DEFAULTS["boundary_size"]

    def __post_init__(self):
        # The config's checks, in its order: each value (the one check of a value), then the
        # rules across parameters, then the step bounds; the first problem is raised.
        for name in PARAMETERS:
            problem = value_problem(name, getattr(self, name))
            if problem:
                raise ValueError(problem)
        quadrature_code(self.quadrature)
        r_min, r_max = self.radius_range
        problem = (contour_points_problem(self.contour_points, self.modes)
                   or dt_problem(self.dt, self.eta, self.modes, self.mu_shape, r_max)
                   or integrator_problem(self.integrator, self.quadrature, self.modes)
                   or core_exponent_problem(self.core_exponent, self.quadrature, self.modes, self.integrator)
                   or size_problem(self.size_distribution, self.initial, self.integrator, self.size_width,
                                   self.adhesion)
                   or boundary_problem(self.boundary, self.boundary_size, self.N, self.density, self.R0, r_max,
                                       self.initial, self.integrator)
                   or step_problem(self.v0, self.dt, r_min, self.contour_points, self.modes)
                   or turn_problem(self.Dr, self.dt))
        if problem:
            raise ValueError(problem)

    @property
    def radii(self):
        """Per-cell radii R0,i drawn from the seed (:func:`fcsweep.model.sizes.cell_radii`),
        ``None`` for monodisperse cells."""
        return cell_radii(self.N, self.seed, self.size_distribution, self.size_ratio, self.size_fraction,
                          self.size_width, self.R0)

    @property
    def radius_range(self) -> tuple[float, float]:
        """(smallest, largest) radius any draw can have (R0, R0 for monodisperse cells)."""
        return radius_bounds(self.size_distribution, self.size_ratio, self.size_fraction, self.size_width, self.R0)

    @property
    def confinement(self):
        """The well or channel (:class:`fcsweep.model.confinement.Confinement`), ``None``
        for the periodic box."""
        reach = self.adhesion_range * self.R0 if self.adhesion > 0.0 else 0.0
        return confinement_of(self.boundary, self.boundary_size, self.N, self.density, self.R0, self.radii, reach)

    @property
    def box(self) -> np.ndarray:
        """Periodic box (Lx, Ly) of the n x n lattice at this density (with sizes: at
        area fraction sum pi R0,i^2 / (Lx Ly), :func:`fcsweep.model.sizes.effective_radius`);
        in a well or a channel the host box of :attr:`confinement`."""
        if self.boundary != "periodic":
            return self.confinement.host.copy()
        R = self.R0 if self.size_distribution == "monodisperse" else effective_radius(self.radii, self.R0)
        _, Lx, Ly = lattice_box(self.N, self.density, R)
        return np.array([Lx, Ly])

    def to_dict(self) -> dict:
        """Plain dict of all fields."""
        return dataclasses.asdict(self)


@dataclass
class State:
    """Full dynamical state.

    Attributes
    ----------
    pos : float64[N, 2]   centres wrapped into the box
    image : int64[N, 2]   box crossings; unwrapped = pos + image * box
    theta : float64[N]    polarity angles (not wrapped)
    a, b : float64[N, M-1]  shape modes n = 2..M
    step : int
    projections : int     admissibility projections so far (cell-steps)
    box : float64[2]
    """

    pos: np.ndarray
    image: np.ndarray
    theta: np.ndarray
    a: np.ndarray
    b: np.ndarray
    box: np.ndarray
    step: int = 0
    projections: int = 0

    def unwrapped(self) -> np.ndarray:
        """Unwrapped centres ``pos + image * box`` (N, 2)."""
        return self.pos + self.image * self.box


class Simulation:
    """Integration of N cells with Euler-Maruyama noise from a PCG64 Generator.

    ``params.integrator`` picks the deterministic step (:data:`INTEGRATORS`): ``"euler"``
    (the paper's explicit step, default), ``"contact-implicit"`` (each contact's normal
    relaxation implicit, so contacts do not chatter) or ``"contact-jacobi"`` (the same
    with each contact's approach rate, solved by Jacobi sweeps; arc quadrature only);
    see :mod:`fcsweep.model.integrators`.

    Use :meth:`create` for the initial state ``params.initial`` names (docs/model.md:
    :meth:`from_lattice`, :meth:`from_disordered` or :meth:`from_coexistence`), :meth:`advance` to integrate,
    and :meth:`to_checkpoint` / :meth:`from_checkpoint` (or :meth:`save` / :meth:`load`)
    to continue a run bit for bit.
    """

    def __init__(self, params: SimParams, state: State, rng: np.random.Generator):
        self.params = params
        self.state = state
        self.rng = rng
        M1 = max(params.modes - 1, 0)
        #: Per-cell radii R0,i (``None`` for monodisperse cells: the kernels then read R0).
        self.radii = params.radii
        #: The well or channel (``None``: the periodic box).
        self.confinement = params.confinement
        self._ws = workspace_for(params.N, params.contour_points, M1, params.box, params.R0, params.quadrature,
                                 params.integrator, radii=self.radii)
        self._periodic = True
        self._quad = quadrature_code(params.quadrature)
        self._warned_pinned = False
        R_min = params.R0 if self.radii is None else float(self.radii.min())
        spacing = 2.0 * math.pi * R_min / params.contour_points
        self._prm = param_vector(
            box=params.box, R0=params.R0, eta=params.eta, v0=params.v0, mu_theta=params.mu_theta,
            mu_shape=params.mu_shape, dt=params.dt, noise_amp=math.sqrt(2.0 * params.Dr * params.dt),
            smax=PROJECTION_MARGIN * ADMISSIBLE_BOUND, dmax=spacing, adhesion=params.adhesion,
            adhesion_range=params.adhesion_range, wall=self.confinement,
            **contact_parameters(params.integrator, params.dt, params.modes, params.R0, params.mu_shape),
            **({} if params.core_exponent == 1.0 else {"core_exponent": params.core_exponent}),
        )

    # ------------------------------------------------------------------ construction
    @staticmethod
    def _params(N, seed, params, caller) -> SimParams:
        unknown = sorted(set(params) - set(PARAMETERS) | ({"N"} & set(params)))
        if unknown:
            raise TypeError(f"{caller}() got unexpected keyword arguments {unknown}")
        return SimParams(N=int(N), seed=int(seed), **{k: PARAMETERS[k].type(v) for k, v in params.items()})

    @classmethod
    def create(cls, N, *, seed, **params) -> "Simulation":
        """The initial state ``params["initial"]`` names (default ``"lattice"``).

        Parameters
        ----------
        N, seed, **params
            As for :meth:`from_lattice`.

        Returns
        -------
        Simulation
            :meth:`from_lattice`, :meth:`from_disordered` or :meth:`from_coexistence`.
        """
        p = cls._params(N, seed, params, "create")
        make = {"disordered": cls.from_disordered, "coexistence": cls.from_coexistence}.get(p.initial, cls.from_lattice)
        return make(N, seed=seed, **params)

    @classmethod
    def from_lattice(cls, N, *, seed, **params) -> "Simulation":
        """Cells on the n x n hexagonal lattice, circular, with uniform random polarity.

        Parameters
        ----------
        N : int
            Number of cells, n*n with n even.
        seed : int
            Seed of the noise and of the initial polarities.
        **params
            The other model parameters by name (``eta`` and ``v0`` required; the rest
            default to :data:`fcsweep.model.parameters.DEFAULTS`): the fields of
            :class:`SimParams`, each converted to its declared type (``initial``, if
            given, is recorded as ``"lattice"``: :meth:`create` dispatches on it).
        """
        p = cls._params(N, seed, params, "from_lattice")
        if p.initial != "lattice":
            p = dataclasses.replace(p, initial="lattice")
        pos, box = hexagonal_lattice(p.N, p.density, p.R0)
        rng = np.random.Generator(np.random.PCG64(p.seed))
        theta = rng.uniform(0.0, 2.0 * np.pi, p.N)
        M1 = max(p.modes - 1, 0)
        state = State(pos=pos, image=np.zeros((p.N, 2), np.int64), theta=theta,
                      a=np.zeros((p.N, M1)), b=np.zeros((p.N, M1)), box=box)
        return cls(p, state, rng)

    @classmethod
    def from_disordered(cls, N, *, seed, relax_time: float = RELAX_TIME, **params) -> "Simulation":
        """An isotropic start: random centres in the lattice's box, relaxed at v0 = 0.

        Centres are uniform in the box (in a well or channel: inside it, R0 from the walls),
        then pushed apart as soft discs
        (:func:`fcsweep.model.disordered.soft_disc_relax`), then the model itself runs
        ``relax_time`` at v0 = 0 without noise and with the polarities held
        (``Dr = mu_theta = 0``) under the run's dt, quadrature and integrator, so that
        positions and shapes relax.  All of it draws from the start's own stream
        (:func:`fcsweep.model.disordered.start_rng`); the polarities and then the noise come
        from ``PCG64(seed)`` exactly as in :meth:`from_lattice`.  The state starts at step 0.

        Parameters
        ----------
        N, seed, **params
            As for :meth:`from_lattice` (``initial`` is recorded as ``"disordered"``).
        relax_time : float
            Duration of the model relaxation (time units).

        Raises
        ------
        SimulationError
            If the relaxation becomes unstable (the message names a safer dt).
        """
        p = dataclasses.replace(cls._params(N, seed, params, "from_disordered"), initial="disordered")
        box = p.box
        srng = start_rng(p.seed)
        conf = p.confinement
        centres = random_centres(p.N, box, srng) if conf is None else conf.random_points(p.N, srng, inset=p.R0)
        pos, _ = soft_disc_relax(centres, box, p.R0, radii=p.radii, confinement=conf)
        return cls._relaxed_start(p, pos, box, srng, relax_time)

    @classmethod
    def _relaxed_start(cls, p: SimParams, pos, box, srng, relax_time: float) -> "Simulation":
        """The end of the disordered and coexistence starts: polarities from ``PCG64(seed)``,
        then ``relax_time`` of the model at v0 = 0, noise and polarities held, drawing
        (nothing) from the start's stream ``srng``; circular cells at ``pos`` before it."""
        rng = np.random.Generator(np.random.PCG64(p.seed))
        theta = rng.uniform(0.0, 2.0 * np.pi, p.N)
        M1 = max(p.modes - 1, 0)
        state = State(pos=pos, image=np.zeros((p.N, 2), np.int64), theta=theta.copy(),
                      a=np.zeros((p.N, M1)), b=np.zeros((p.N, M1)), box=box.copy())
        relax = cls(dataclasses.replace(p, v0=0.0, Dr=0.0, mu_theta=0.0), state, srng)
        relax.advance(int(round(relax_time / p.dt)))
        state = State(pos=relax.state.pos, image=np.zeros((p.N, 2), np.int64), theta=theta,
                      a=relax.state.a, b=relax.state.b, box=box)
        return cls(p, state, rng)

    @classmethod
    def from_coexistence(cls, N, *, seed, relax_time: float = RELAX_TIME, **params) -> "Simulation":
        """A crystal | fluid start: half the box's rows on the lattice, the rest a disordered
        packing, two flat interfaces along x, relaxed at v0 = 0.

        The slab is the lattice's rows ``n/4 <= j < 3n/4`` (``N/2`` cells); ``N/2`` centres
        uniform in the other half of the box are pushed apart as soft discs with the slab's
        cells held (:func:`fcsweep.model.coexistence.coexistence_centres`), so both halves
        are at the run's area fraction.  Then, as in :meth:`from_disordered`, the model runs
        ``relax_time`` at v0 = 0 without noise and with the polarities held, every cell
        free: without activity or noise the slab cannot melt, and the cells at the
        interfaces take up the packing's pressure.  The start draws from its own stream
        (:func:`fcsweep.model.coexistence.coexistence_rng`); the polarities and then the
        noise come from ``PCG64(seed)`` exactly as in :meth:`from_lattice`.

        Parameters
        ----------
        N, seed, **params
            As for :meth:`from_lattice` (``initial`` is recorded as ``"coexistence"``);
            ``N >= 64`` (:func:`fcsweep.model.coexistence.coexistence_problem`).
        relax_time : float
            Duration of the model relaxation (time units).

        Raises
        ------
        ValueError
            If N is too small for a slab and a band, or the parameters need another start
            (cell sizes, walls).
        SimulationError
            If the relaxation becomes unstable.
        """
        p = dataclasses.replace(cls._params(N, seed, params, "from_coexistence"), initial="coexistence")
        problem = coexistence_problem(p.N, p.initial)
        if problem:
            raise ValueError(problem)
        srng = coexistence_rng(p.seed)
        pos, _, box = coexistence_centres(p.N, p.density, p.R0, srng)
        return cls._relaxed_start(p, pos, box, srng, relax_time)

    # ------------------------------------------------------------------ dynamics
    @property
    def time(self) -> float:
        """Simulated time, ``step * dt``."""
        return self.state.step * self.params.dt

    def advance(self, steps: int) -> None:
        """Integrate ``steps`` steps of ``params.integrator``.

        Raises
        ------
        SimulationError
            If a rate becomes non-finite or a cell moves more than the contour spacing
            in one step; the state is left at the failing step.
        """
        steps = int(steps)
        if steps < 0:
            raise ValueError(f"steps must be >= 0; got {steps}")
        s = self.state
        ws = self._ws
        self._check_state()
        threads = numba.get_num_threads()
        numba.set_num_threads(max(1, min(threads, self.params.N // CELLS_PER_THREAD)))
        try:
            done = 0
            proj_before = s.projections
            while done < steps:
                n = min(CHUNK, steps - done)
                noise = self.rng.standard_normal((n, self.params.N))
                used = 0
                while used < n:
                    k, status, nproj = run_chunk(s.pos, s.image, s.theta, s.a, s.b, noise[used:], self._prm,
                                                 self._periodic, self._quad, ws.tables, ws.scratch, ws.cl, ws.nl,
                                                 ws.out, ws.flags)
                    s.step += int(k)
                    s.projections += int(nproj)
                    used += int(k)
                    if status == LIST_FULL:
                        ws.grow_neighbour_list()
                    elif status != OK:
                        raise SimulationError(self._failure_message(status))
                done += n
                pinned = (s.projections - proj_before) / (n * self.params.N)
                proj_before = s.projections
                if pinned > PINNED_WARNING and not self._warned_pinned:
                    self._warned_pinned = True
                    warnings.warn(
                        f"{pinned:.0%} of cell-steps were projected back onto the admissibility bound "
                        f"(steps {s.step - n}-{s.step}); unless eta is tiny this means dt={self.params.dt:g} "
                        f"is too large: try dt={self.params.dt / 4:g}", RuntimeWarning, stacklevel=2)
        finally:
            numba.set_num_threads(threads)

    def run(self, time: float, every: float) -> Frames:
        """Integrate ``time`` time units and record the state now and every ``every`` time
        units after, in memory.

        The frames are those a sweep run samples every ``every / dt`` steps (the first at
        the present step): the same values its ``trajectory.h5`` stores, so that
        :func:`fcsweep.observables` of them equals what ``fcsweep analyze`` stores.  Called
        again, it continues the run (its first frame repeats the last one of before).

        Parameters
        ----------
        time : float
            Time units to integrate: a whole number of steps ``dt``.
        every : float
            Time units between frames: a whole number of steps that divides ``time``.

        Returns
        -------
        fcsweep.frames.Frames
            ``time / every + 1`` frames.
        """
        n, k = self._whole_steps(time, "time"), self._whole_steps(every, "every")
        if k == 0 or n % k:
            raise ValueError(f"every = {every!r} must be a whole number of steps (dt = {self.params.dt:g}) that "
                             f"divides time = {time!r}")
        snapshots = [self._snapshot()]
        for _ in range(n // k):
            self.advance(k)
            snapshots.append(self._snapshot())
        return Frames.from_snapshots(snapshots, self.params.to_dict(), self.state.box, self.radii)

    def _whole_steps(self, duration: float, name: str) -> int:
        steps = float(duration) / self.params.dt
        if not math.isfinite(steps) or steps < 0 or abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
            raise ValueError(f"{name} = {duration!r} must be >= 0 and a whole number of steps dt = {self.params.dt:g}")
        return int(round(steps))

    def _snapshot(self) -> dict:
        s = self.state
        return {"step": int(s.step), "time": float(s.step) * float(self.params.dt), "position": s.pos.copy(),
                "image": s.image.copy(), "theta": s.theta.copy(), "shape_a": s.a.copy(), "shape_b": s.b.copy()}

    def _check_state(self) -> None:
        """Refuse to step a state with non-finite values (set from outside: the kernels
        stop before writing any); they would corrupt the cell list."""
        s = self.state
        for name in ("pos", "theta", "a", "b"):
            x = getattr(s, name).reshape(self.params.N, -1)
            bad = np.flatnonzero(~np.isfinite(x).all(axis=1))
            if bad.size:
                raise SimulationError(f"state.{name} has non-finite values for {bad.size} cell(s) (first: "
                                      f"{bad[:5].tolist()}) at step {s.step}; nothing was integrated")

    def _failure_message(self, status) -> str:
        p = self.params
        bad = np.flatnonzero(self._ws.flags & (1 if status == NONFINITE else 2))
        what = "non-finite rates" if status == NONFINITE else "a cell moved more than the contour spacing in one step"
        safer = p.dt / 4
        speed = np.hypot(*self._ws.out[0][bad].T) if bad.size else np.zeros(0)
        if status != NONFINITE and speed.size and np.isfinite(speed).all():
            # the step at which the fastest of these cells would move half the spacing
            safer = min(safer, 0.5 * self._prm[P_DMAX] / speed.max())
        hint = (f"dt={p.dt:g} is probably too large for eta={p.eta:g}, v0={p.v0:g}; "
                f"try dt={safer:.2g} (the paper uses 5e-3)")
        return (f"unstable at step {self.state.step}: {what} for {len(bad)} cell(s) "
                f"(first: {bad[:5].tolist()}); {hint}")

    def rates(self) -> dict:
        """Deterministic rates of the current state (computed by the kernels)."""
        from .kernels.api import kernel_rates

        s, p = self.state, self.params
        return kernel_rates(s.pos, s.theta, s.a, s.b, eta=p.eta, v0=p.v0, box=p.box, R0=p.R0,
                            contour_points=p.contour_points, quadrature=p.quadrature,
                            mu_theta=p.mu_theta, mu_shape=p.mu_shape, adhesion=p.adhesion,
                            adhesion_range=p.adhesion_range, core_exponent=p.core_exponent, radii=self.radii,
                            wall=self.confinement)

    # ------------------------------------------------------------------ persistence
    def to_checkpoint(self) -> dict:
        """Full state as a flat dict of arrays, numbers and JSON strings."""
        s = self.state
        return {
            "pos": s.pos.copy(), "image": s.image.copy(), "theta": s.theta.copy(),
            "a": s.a.copy(), "b": s.b.copy(), "box": s.box.copy(),
            "step": int(s.step), "projections": int(s.projections),
            "params_json": json.dumps(self.params.to_dict(), sort_keys=True),
            "rng_state_json": json.dumps(self.rng.bit_generator.state),
            "fcsweep_version": __version__,
            **({} if self.radii is None else {"radii": self.radii.copy()}),
        }

    @classmethod
    def from_checkpoint(cls, ck) -> "Simulation":
        """Rebuild a simulation from :meth:`to_checkpoint` output (or a loaded npz)."""
        def scalar(x):
            return np.asarray(x).item()

        stored = json.loads(str(scalar(ck["params_json"])))
        stored.setdefault("quadrature", "binary")  # the only rule before the option existed
        stored.setdefault("integrator", DEFAULT_INTEGRATOR)  # the only scheme before the option existed
        stored.setdefault("initial", "lattice")  # the only start before the option existed
        params = SimParams(**stored)
        if "radii" in ck and not np.array_equal(np.asarray(ck["radii"], float), params.radii):
            raise ValueError("the checkpoint's radii differ from those its parameters and seed draw")
        rng = np.random.Generator(np.random.PCG64())
        rng.bit_generator.state = json.loads(str(scalar(ck["rng_state_json"])))
        state = State(pos=np.array(ck["pos"], float), image=np.array(ck["image"], np.int64),
                      theta=np.array(ck["theta"], float), a=np.array(ck["a"], float), b=np.array(ck["b"], float),
                      box=np.array(ck["box"], float), step=int(scalar(ck["step"])),
                      projections=int(scalar(ck["projections"])))
        return cls(params, state, rng)

    def save(self, path) -> None:
        """Write the full state to an ``.npz`` file atomically and durably
        (:func:`fcsweep.io.atomic.atomic_write` with fsync: a reader sees the previous
        file or the complete new one)."""
        data = self.to_checkpoint()

        def write(tmp) -> None:
            with open(tmp, "wb") as fh:  # a file object: np.savez would add ".npz" to a name
                np.savez(fh, **data)

        atomic_write(path, write, fsync=True)

    @classmethod
    def load(cls, path) -> "Simulation":
        """Read a state written by :meth:`save`."""
        with np.load(os.fspath(path), allow_pickle=False) as z:
            return cls.from_checkpoint({k: z[k] for k in z.files})
