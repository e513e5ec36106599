"""With every extension at its default, is this tree's trajectory main's, bit for bit?

    git archive <main commit> | tar -x -C /tmp/main_ref
    NUMBA_NUM_THREADS=1 python benchmarks/extensions_bitwise.py --main /tmp/main_ref

Runs the same short simulations (16 settings: each quadrature, modes 0 / 6 / 8, K = 30,
both starts, the contact integrators, N = 16 all-image and N = 64 neighbour-list paths)
in a subprocess on each tree and compares a SHA-256 of the final positions, images,
angles and shape modes.  Prints one line per setting; exits 1 on any difference.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
SETTINGS = [
    (64, {"quadrature": "binary"}), (64, {"quadrature": "arc"}), (64, {"quadrature": "arc", "initial": "disordered"}),
    (64, {"quadrature": "binary", "modes": 0}), (16, {"quadrature": "binary", "modes": 0}),
    (64, {"quadrature": "linear", "initial": "disordered"}), (64, {"quadrature": "arc", "integrator": "contact-implicit"}),
    (64, {"quadrature": "arc", "integrator": "contact-jacobi"}),
    (64, {"quadrature": "binary", "integrator": "contact-implicit", "initial": "disordered"}),
    (64, {"quadrature": "binary", "modes": 8}), (64, {"quadrature": "arc", "modes": 8}),
    (64, {"quadrature": "linear", "modes": 8}), (64, {"quadrature": "binary", "contour_points": 30}),
    (16, {"quadrature": "arc"}), (16, {"quadrature": "binary"}), (16, {"quadrature": "binary", "initial": "disordered"}),
]


def _hashes(steps: int) -> list[str]:
    import numpy as np

    from fcsweep.simulation import Simulation

    out = []
    for N, kw in SETTINGS:
        sim = Simulation.create(N, seed=78, eta=0.05, v0=0.05, **kw)
        sim.advance(steps)
        s = sim.state
        out.append(hashlib.sha256(b"".join(np.ascontiguousarray(x).tobytes()
                                           for x in (s.pos, s.image, s.theta, s.a, s.b))).hexdigest()[:16])
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--main", type=Path, default=Path("/tmp/main_ref"), help="a copy of main's tree")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(_hashes(args.steps)))
        return 0
    got = {}
    for name, tree in (("main", args.main), ("this", HERE)):
        env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_NUM_THREADS": os.environ.get("NUMBA_NUM_THREADS", "1")}
        res = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker", "--steps", str(args.steps)],
                             cwd=str(tree), env=env, capture_output=True, text=True, check=True)
        got[name] = json.loads(res.stdout.strip().splitlines()[-1])
    bad = 0
    for (N, kw), a, b in zip(SETTINGS, got["main"], got["this"]):
        bad += a != b
        print(f"N={N:3d} {json.dumps(kw):70s} main {a}  this {b}  {'same' if a == b else 'DIFFERENT'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
