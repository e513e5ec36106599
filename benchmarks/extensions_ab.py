"""Interleaved A/B step timings of the model extensions (issue 35): this tree against a
frozen copy of main, and the cost of each extension switched on.

    git archive <main commit> | tar -x -C /tmp/main_ref
    NUMBA_NUM_THREADS=1 python benchmarks/extensions_ab.py --main /tmp/main_ref

One worker process per variant (main's tree, this tree) stays up for the whole run, each
with its own warm numba cache; the driver asks them in turn for one block of steps, so
that the machine's load drifts over both alike.  Per quadrature (binary, arc) at N = 1024
it reports cell-steps/s as the median over ``--blocks`` blocks (>= 5), the ratio
this / main, and whether both trees give the same state to the bit after the same steps
(extensions off: they must).  Then this tree with each extension on against off:
``size_distribution: bidisperse`` (disordered start, both rules), ``core_exponent: 2``
(arc rule only) and ``boundary: well`` / ``channel`` (disordered start, both rules: the same
confined packing stepped with the wall term and without it, so that the ratio is the wall
term's cost and not a difference of packings).  ``--only`` picks some of them.  No file is
written; the table goes to stdout.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]


def _worker() -> None:
    """Serve ``{"key": ..., "params": {...}, "steps": n}`` lines: build (once per key) and
    time ``steps`` steps; answer cell-steps/s and a hash of the state."""
    from fcsweep.simulation import Simulation

    sims = {}
    for line in sys.stdin:
        req = json.loads(line)
        key = req["key"]
        if key not in sims:
            p = dict(req["params"])
            N, seed = p.pop("N"), p.pop("seed")
            if p.get("initial") == "disordered":
                sims[key] = Simulation.from_disordered(N, seed=seed, relax_time=req.get("relax", 1.0), **p)
            else:
                sims[key] = Simulation.create(N, seed=seed, **p)
            if req.get("wall_off"):  # the same confined packing without the wall term's work
                from fcsweep.kernels.records import P_WALL
                sims[key]._prm[P_WALL] = 0.0
            sims[key].advance(10)  # compile / warm
        sim = sims[key]
        clock = time.process_time if req.get("cpu") else time.perf_counter
        t0 = clock()
        sim.advance(int(req["steps"]))
        dt = clock() - t0
        s = sim.state
        h = hashlib.sha256(b"".join(np.ascontiguousarray(x).tobytes() for x in (s.pos, s.theta, s.a, s.b)))
        print(json.dumps({"rate": sim.params.N * int(req["steps"]) / dt, "hash": h.hexdigest()[:16],
                          "step": int(s.step)}), flush=True)


class _Worker:
    def __init__(self, tree: Path):
        env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_NUM_THREADS": os.environ.get("NUMBA_NUM_THREADS", "1")}
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--worker"], cwd=str(tree),
                                     env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    cpu = False

    def ask(self, **req) -> dict:
        req["cpu"] = self.cpu
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError("worker died")
        return json.loads(line)

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def _compare(label, a: _Worker, ka, pa, b: _Worker, kb, pb, steps, blocks, same_state) -> None:
    ra, rb = [], []
    identical = True
    for _ in range(blocks):
        x = a.ask(**ka, steps=steps) if isinstance(ka, dict) else a.ask(key=ka, params=pa, steps=steps)
        y = b.ask(key=kb, params=pb, steps=steps)
        ra.append(x["rate"])
        rb.append(y["rate"])
        identical &= x["hash"] == y["hash"]
    ma, mb = float(np.median(ra)), float(np.median(rb))
    extra = f"  bitwise {'identical' if identical else 'DIFFERENT'}" if same_state else ""
    print(f"{label:44s} {ma:12.4g} {mb:12.4g} {mb / ma:8.4f}  (blocks a {np.round(np.array(ra) / ma, 3).tolist()}, "
          f"b {np.round(np.array(rb) / mb, 3).tolist()}){extra}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--main", type=Path, default=Path("/tmp/main_ref"), help="a copy of main's tree")
    ap.add_argument("--N", type=int, default=1024)
    ap.add_argument("--blocks", type=int, default=5)
    ap.add_argument("--steps", type=int, default=200, help="steps per block")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--skip-ab", action="store_true", help="only the extensions' costs")
    ap.add_argument("--skip-extensions", action="store_true", help="only the A/B against main")
    ap.add_argument("--swap", action="store_true", help="ask this tree before main in each block (order check)")
    ap.add_argument("--quadratures", default="binary,arc", help="comma list (default binary,arc)")
    ap.add_argument("--only", default="sizes,core,boundary", help="extensions to time (default all: sizes,core,boundary)")
    ap.add_argument("--cpu", action="store_true",
                    help="time each block by the worker's CPU time (time.process_time: less sensitive to other "
                         "load on a shared machine) instead of wall time")
    args = ap.parse_args()
    if args.worker:
        _worker()
        return
    blocks = max(5, args.blocks)
    base = {"N": args.N, "seed": 3, "eta": 0.05, "v0": 0.03}
    quads = [q for q in args.quadratures.split(",") if q]
    _Worker.cpu = bool(args.cpu)
    ours = _Worker(HERE)
    print(f"timing: {'CPU' if args.cpu else 'wall'} time, N = {args.N}, {args.steps} steps x {blocks} blocks", flush=True)
    print(f"{'comparison (a / b)':44s} {'a cell-st/s':>12s} {'b cell-st/s':>12s} {'b / a':>8s}", flush=True)
    if not args.skip_ab:
        ref = _Worker(args.main)
        for q in quads:
            p = {**base, "quadrature": q}
            if args.swap:
                _compare(f"this / main, extensions off, {q}", ours, q, p, ref, q, p, args.steps, blocks, True)
            else:
                _compare(f"main / this, extensions off, {q}", ref, q, p, ours, q, p, args.steps, blocks, True)
        ref.close()
    if args.skip_extensions:
        ours.close()
        return
    only = set(args.only.split(","))
    for q in quads:
        off = {**base, "quadrature": q, "initial": "disordered"}
        if "sizes" in only:
            _compare(f"this: sizes off / bidisperse, {q}", ours, f"d{q}", off, ours, f"s{q}",
                     {**off, "size_distribution": "bidisperse"}, args.steps, blocks, False)
        for boundary in ("well", "channel") if "boundary" in only else ():
            conf = {**off, "boundary": boundary}
            a_req = dict(key=f"{boundary}{q}-off", params=conf, wall_off=True)
            _compare(f"this: {boundary} wall term off / on, {q}", ours, a_req, None, ours, f"{boundary}{q}", conf,
                     args.steps, blocks, False)
    off = {**base, "quadrature": "arc"}
    if "arc" in quads and "core" in only:
        _compare("this: core_exponent 1 / 2, arc", ours, "arc", off, ours, "core", {**off, "core_exponent": 2.0},
                 args.steps, blocks, False)
    ours.close()


if __name__ == "__main__":
    main()
