"""Interleaved A/B timing of the step: a reference tree (main) against this tree with
adhesion off, and this tree with adhesion on; and the bit-identity of the trajectories.

Usage:
    git archive f99d8d6 | tar -x -C /tmp/main_ref_adh
    python benchmarks/adhesion_ab.py --ref /tmp/main_ref_adh [--blocks 7] [--N 1024]

For each quadrature (binary, arc) three worker processes are started, each with its own
tree on PYTHONPATH and one numba thread: ``ref`` (the reference tree), ``off`` (this tree,
``adhesion`` not given) and ``on`` (this tree, ``adhesion: 0.1``).  Each builds the same
run (N cells on the lattice, eta = 0.03, v0 = 0.06, seed 1), integrates ``--warm`` steps
and then times blocks of ``--steps`` steps in turn ref, off, on, ref, off, on, ... so
that the machine's load falls alike on all three.  Printed: the median over blocks of
the CPU time per cell-step (process time: other sessions on the machine slow the wall
clock, not the process clock) and of the wall time, the medians of the per-block ratios
off/ref and on/off, and whether ref and off hold the same state to the last bit after
the same steps.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent


def worker(args):
    """Serve ``time`` requests on stdin: integrate one block, answer its timings."""
    import numpy as np

    from fcsweep.simulation import Simulation

    extra = {} if args.adhesion is None else {"adhesion": args.adhesion}
    sim = Simulation.from_lattice(args.N, eta=0.03, v0=0.06, Dr=0.01, seed=1, quadrature=args.quadrature[0],
                                  **extra)
    sim.advance(args.warm)
    print(json.dumps({"ready": True}), flush=True)
    for line in sys.stdin:
        if line.strip() != "time":
            break
        c0, w0 = time.process_time(), time.perf_counter()
        sim.advance(args.steps)
        c1, w1 = time.process_time(), time.perf_counter()
        s = sim.state
        digest = hashlib.sha256(b"".join(np.ascontiguousarray(x).tobytes()
                                         for x in (s.pos, s.image, s.theta, s.a, s.b))).hexdigest()
        print(json.dumps({"cpu": c1 - c0, "wall": w1 - w0, "state": digest, "step": s.step}), flush=True)


def start(tree, quadrature, adhesion, args):
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS="1")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", "--quadrature", quadrature, "--N", str(args.N),
           "--steps", str(args.steps[quadrature]), "--warm", str(args.warm)]
    if adhesion is not None:
        cmd += ["--adhesion", str(adhesion)]
    p = subprocess.Popen(cmd, cwd=str(tree), env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    return p


def ask(p):
    p.stdin.write("time\n")
    p.stdin.flush()
    return json.loads(p.stdout.readline())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--ref", type=Path, default=Path("/tmp/main_ref_adh"), help="the reference tree (main)")
    ap.add_argument("--N", type=int, default=1024)
    ap.add_argument("--blocks", type=int, default=7)
    ap.add_argument("--warm", type=int, default=300)
    ap.add_argument("--steps", type=int, default=None, help="steps per block (default 200 binary, 80 arc)")
    ap.add_argument("--quadrature", nargs="+", default=["binary", "arc"])
    ap.add_argument("--adhesion", type=float, default=None)
    args = ap.parse_args(argv)
    if args.worker:
        args.steps = args.steps or 100
        return worker(args)
    args.steps = {q: args.steps or (200 if q == "binary" else 80) for q in args.quadrature}
    for q in args.quadrature:
        procs = {"ref": start(args.ref, q, None, args), "off": start(HERE, q, None, args),
                 "on": start(HERE, q, 0.1, args)}
        for p in procs.values():  # compiled and warm
            assert json.loads(p.stdout.readline())["ready"]
        res = {k: [] for k in procs}
        for _ in range(args.blocks):
            for k, p in procs.items():
                res[k].append(ask(p))
        for p in procs.values():
            p.stdin.close()
            p.wait()
        cells = args.N * args.steps[q]
        med = {k: {t: statistics.median(r[t] for r in v) / cells * 1e6 for t in ("cpu", "wall")}
               for k, v in res.items()}
        ratio = {t: {"off/ref": statistics.median(o[t] / r[t] for o, r in zip(res["off"], res["ref"])),
                     "on/off": statistics.median(n[t] / o[t] for n, o in zip(res["on"], res["off"]))}
                 for t in ("cpu", "wall")}
        same = all(o["state"] == r["state"] and o["step"] == r["step"] for o, r in zip(res["off"], res["ref"]))
        print(json.dumps({"quadrature": q, "N": args.N, "blocks": args.blocks, "steps_per_block": args.steps[q],
                          "us_per_cell_step_median": med, "ratio_median": ratio,
                          "cell_steps_per_s_cpu": {k: 1e6 / v["cpu"] for k, v in med.items()},
                          "ref_off_states_bit_identical": same}, indent=1), flush=True)


if __name__ == "__main__":
    main()
