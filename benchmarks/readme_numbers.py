"""Measure the numbers the README and the config comments quote; write them to one place.

Writes ``benchmarks/results/readme_numbers.json``: the first hour's wall times without the
install (``fcsweep compile`` from a cold cache in a temporary ``NUMBA_CACHE_DIR``, the
demo's ``simulate``, ``analyze`` + ``aggregate`` + ``plot`` and ``movie 0`` in a fresh
directory with those kernels), the size of the test suite (its time only with
``--suite``), and the CPU cost of every ``configs/*.yaml`` from the cost model
(:mod:`fcsweep.sweep.cost`), with the date and the machine's load (a loaded machine
gives longer times: the load average is recorded beside them).  The README and the pages
of docs/ quote these numbers (``quotes``: a regex and the text it must find, checked by
``tests/test_docs_code.py``; the test count is also checked against the tests pytest
collects), and each config carries a generated ``# cost:`` comment line.  Unless
``--no-rewrite``, the quotes of the numbers measured in a call are rewritten in README.md
and docs/*.md; ``--rewrite-only`` rewrites them from the file without measuring.

Usage:
    python benchmarks/readme_numbers.py                 # everything but the suite (about 10 min)
    python benchmarks/readme_numbers.py --only configs  # re-cost the configs and rewrite their cost lines
    python benchmarks/readme_numbers.py --only compile --only demo --no-rewrite
    python benchmarks/readme_numbers.py --only tests    # the test count, after tests were added
    python benchmarks/readme_numbers.py --suite         # also time the default test suite (minutes)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "readme_numbers.json"
FCSWEEP = [sys.executable, "-m", "fcsweep.cli"]
#: Configs that get no cost line: smoke.yaml must stay identical to the built-in demo
#: (fcsweep/data/smoke.yaml), whose cost the demo timing above gives.
NO_COST_LINE = ("smoke.yaml",)


def _wall(args, cwd, env=None) -> float:
    t0 = time.perf_counter()
    subprocess.run(FCSWEEP + args, cwd=cwd, check=True, capture_output=True, env=env)
    return time.perf_counter() - t0


def measure_first_hour(compile_cold: bool = True, demo: bool = True) -> dict:
    """Wall seconds of ``fcsweep compile`` from an empty cache (a temporary
    ``NUMBA_CACHE_DIR``, so the user's cache is neither used nor touched), then, with
    those kernels, of the built-in demo in a fresh directory: ``simulate``, ``analyze`` +
    ``aggregate`` + ``plot``, and ``movie 0``.  Without ``compile_cold`` the demo uses
    the usual cache (compiled first if cold, untimed)."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ)
        if compile_cold:
            env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba-cache")
            out["compile_cold_s"] = round(_wall(["compile"], tmp, env), 1)
        else:
            _wall(["compile"], tmp, env)
        if demo:
            out["demo_simulate_s"] = round(_wall(["simulate", "-q"], tmp, env), 1)
            out["demo_analysis_s"] = round(sum(_wall([c], tmp, env) for c in ("analyze", "aggregate", "plot")), 1)
            out["demo_movie_s"] = round(_wall(["movie", "0"], tmp, env), 1)
    return out


def count_tests() -> dict:
    """Tests the default ``python -m pytest`` selects (slow ones deselected) and in all."""
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q"], cwd=ROOT,
                         capture_output=True, text=True).stdout
    m = re.search(r"(\d+)(?:/(\d+))? tests? collected", out)
    if not m:
        raise RuntimeError(f"cannot read the test count from pytest:\n{out[-2000:]}")
    selected, total = int(m.group(1)), int(m.group(2) or m.group(1))
    return {"tests_default": selected, "tests_all": total}


def time_suite() -> dict:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-x"], cwd=ROOT, check=True, capture_output=True)
    return {"suite_wall_s": round(time.perf_counter() - t0), "suite_date": time.strftime("%Y-%m-%d")}


def _cpu_text(seconds: float) -> str:
    if seconds < 2 * 3600:
        return f"~{seconds / 60:.2g} CPU-minutes"
    if seconds < 48 * 3600:
        return f"~{seconds / 3600:.2g} CPU-hours"
    return f"~{seconds / 86400:.2g} CPU-days"


def cost_configs(log=print) -> dict:
    """Cost of every config (cost model; measured at one thread, cached) and its comment line."""
    from fcsweep.config import load_config
    from fcsweep.sweep.bench import StepCost, first_stop, run_cpu_seconds, setting_groups
    from fcsweep.sweep.cost import cell_step_seconds, setting_points
    from fcsweep.sweep.warmup import compile_kernels

    compile_kernels(log)
    out = {}
    for path in sorted((ROOT / "configs").glob("*.yaml")):
        if path.name in NO_COST_LINE:
            continue
        cfg = load_config(path)
        run = cfg.run
        work = work_min = cpu = cpu_min = 0.0
        us = []
        for key, specs in setting_groups(cfg).items():
            c = cell_step_seconds(setting_points(specs), log=log)
            sc = StepCost(c.rate, 1.0, c.source)
            checkpoints = -(-run.steps // run.checkpoint_every)
            least = first_stop(run)
            for s in specs:
                N = int(s.params["N"])
                work += N * run.steps
                work_min += N * least
                cpu += run_cpu_seconds(s.params, run.steps, checkpoints, sc)
                cpu_min += run_cpu_seconds(s.params, least, -(-least // run.checkpoint_every), sc)
            us.append(f"{c.seconds * 1e6:.2g}")
        rate = f"{'/'.join(dict.fromkeys(us))} us per cell-step at one thread per run"
        if run.until:
            text = (f"# cost: {work_min:.2g} to {work:.2g} cell-steps, {_cpu_text(cpu_min)} (every run settled "
                    f"at its first check) to {_cpu_text(cpu)} (every run to the cap); {rate}")
        else:
            text = f"# cost: {work:.2g} cell-steps, {_cpu_text(cpu)} ({len(cfg.runs())} runs); {rate}"
        out[path.name] = {"cell_steps": work, "cpu_seconds": cpu, "cell_steps_min": work_min if run.until else None,
                          "cpu_seconds_min": cpu_min if run.until else None, "comment": text}
        log(text + f"   <- {path.name}")
    return out


def write_cost_line(path: Path, line: str) -> None:
    """Replace the ``# cost:`` line of a config, or add one at the end of its header comment."""
    lines = path.read_text().splitlines(keepends=True)
    for i, ln in enumerate(lines):
        if ln.startswith("# cost:"):
            lines[i] = line + "\n"
            break
    else:
        i = 0
        while i < len(lines) and lines[i].startswith("#"):
            i += 1
        lines.insert(i, line + "\n")
    path.write_text("".join(lines))


def _fmt_s(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds >= 10 else f"{seconds:.1f} s"


def quotes(data: dict) -> list[dict]:
    """What the README says, as (regex with one group, the text it must read)."""
    q = []
    if "demo_simulate_s" in data:
        q += [{"key": "demo_simulate_s", "pattern": r"fcsweep-demo \(about ([^)]*)\)",
               "text": _fmt_s(data["demo_simulate_s"])},
              {"key": "demo_simulate_s", "pattern": r"`fcsweep simulate` on the demo took\s+\*\*([^*]+)\*\*",
               "text": _fmt_s(data["demo_simulate_s"])},
              {"key": "demo_analysis_s", "pattern": r"`analyze` \+ `aggregate` \+\s+`plot` \*\*([^*]+)\*\*",
               "text": _fmt_s(data["demo_analysis_s"])}]
    # the compile and movie times are quoted once a document says them this way
    for key, pattern in (("compile_cold_s", r"`fcsweep compile` from a cold cache took\s+\*\*([^*]+)\*\*"),
                         ("demo_movie_s", r"`fcsweep movie 0` on the demo took\s+\*\*([^*]+)\*\*")):
        if key in data and any(re.search(pattern, doc.read_text()) for doc in QUOTING):
            q.append({"key": key, "pattern": pattern, "text": _fmt_s(data[key])})
    # the number of tests is recorded in the json, not quoted: no document goes stale when a test is added
    if "suite_wall_s" in data:
        m, s = divmod(int(data["suite_wall_s"]), 60)
        q.append({"key": "suite_wall_s", "pattern": r"the default test suite took\s+\*\*([^*]+)\*\*",
                  "text": f"{m} min {s} s"})
    cfgs = data.get("configs", {})
    if "phase.yaml" in cfgs:
        q.append({"key": "configs/phase.yaml", "pattern": r"`configs/phase.yaml` \(binary\) takes\s+\*\*([^*]+)\*\*",
                  "text": f"{cfgs['phase.yaml']['cpu_seconds'] / 3600:.2g} CPU-hours"})
    if "paper_phase.yaml" in cfgs:
        q.append({"key": "configs/paper_phase.yaml", "pattern": r"the phase diagram at paper scale\s+\*\*([^*]+)\*\*",
                  "text": _cpu_text(cfgs["paper_phase.yaml"]["cpu_seconds"])})
    return q


#: The documents that quote the numbers.
QUOTING = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: Keys of the quotes each part measures.
MEASURES = {"compile": ("compile_cold_s",), "demo": ("demo_simulate_s", "demo_analysis_s", "demo_movie_s"),
            "tests": ("tests_default",), "suite": ("suite_wall_s",)}


def rewrite_quotes(data: dict, keys) -> list[str]:
    """Put the measured text into every place a document quotes it (the group of each quote's
    pattern); returns the documents changed."""
    changed = []
    for doc in QUOTING:
        text = new = doc.read_text()
        for q in data["quotes"]:
            if q["key"] in keys:
                new = re.sub(q["pattern"], lambda m, q=q: m.group(0)[:m.start(1) - m.start(0)] + q["text"]
                             + m.group(0)[m.end(1) - m.start(0):], new)
        if new != text:
            doc.write_text(new)
            changed.append(doc.relative_to(ROOT).as_posix())
    return changed


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", action="append", choices=["compile", "demo", "tests", "configs"],
                    help="measure only these parts (repeatable); the others keep their values")
    ap.add_argument("--suite", action="store_true", help="also time the default test suite")
    ap.add_argument("--no-rewrite", action="store_true", help="write the json only, not the quotes in the docs")
    ap.add_argument("--rewrite-only", action="store_true",
                    help="measure nothing: put the json's numbers into the docs' quotes")
    a = ap.parse_args(argv)
    data = json.loads(OUT.read_text()) if OUT.exists() else {}
    if a.rewrite_only:
        data["quotes"] = quotes(data)
        OUT.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        for doc in rewrite_quotes(data, {q["key"] for q in data["quotes"]}):
            print(f"rewrote the quoted numbers in {doc}")
        return
    parts = set(a.only or ["compile", "demo", "tests", "configs"])
    if parts & {"compile", "demo"}:
        data.update(measure_first_hour("compile" in parts, "demo" in parts))
    if "tests" in parts:
        data.update(count_tests())
    if a.suite:
        data.update(time_suite())
    if "configs" in parts:
        data["configs"] = cost_configs()
        for name, entry in data["configs"].items():
            write_cost_line(ROOT / "configs" / name, entry["comment"])
    data["measured"] = {"date": time.strftime("%Y-%m-%d %H:%M"), "parts": sorted(parts),
                        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                        "load_average": [round(x, 2) for x in os.getloadavg()]}
    data["quotes"] = quotes(data)
    OUT.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    measured = {k for part in parts | ({"suite"} if a.suite else set()) for k in MEASURES.get(part, ())}
    for doc in ([] if a.no_rewrite else rewrite_quotes(data, measured)):
        print(f"rewrote the quoted numbers in {doc}")
    print(json.dumps({k: v for k, v in data.items() if k not in ("configs", "quotes")}, indent=1))


if __name__ == "__main__":
    main()
