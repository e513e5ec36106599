"""Config validation under fuzzing and at its resource bounds.

A seeded mutator damages ``configs/phase.yaml`` (values, keys, structure and raw text);
``fcsweep validate`` must answer each mutant with exit 0 or with exit 2 and one line on
stderr per problem, never a traceback, and never through the last-resort net of ``parse_config``.
"""

from __future__ import annotations

import os
import random
import re
import time
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import (
    MAX_CONFIG_BYTES,
    MAX_LISTED,
    MAX_RUNS,
    UNCHECKED,
    ConfigError,
    check_memory,
    load_config,
    parse_config,
    run_memory_bytes,
)

ROOT = Path(__file__).resolve().parents[1]
PHASE = (ROOT / "configs" / "phase.yaml").read_text()

#: Values a mutant may put anywhere: wrong types, boundary and absurd magnitudes.
NASTY = [0, 1, 2, -1, 0.5, -0.0, 1e-320, 1e-7, 1e300, 10**30, 2**63, float("inf"), float("nan"), True, None,
         "", "x", "1e3", "\x00", "é" * 300, [], {}, [1, [2, [3]]], {"start": 0, "stop": 1, "num": 10**9},
         {"start": 1, "stop": 2}, [0.1, 0.1], 36, 16, 25, 1024]
TEXT_JUNK = ["[", "]", "{", "}", ":", "- ", "\t", "&a ", "*a", "? ", "!!python/object:os.system ", "\x00", "\xff",
             "'", '"', "#", "\n", "  ", "%YAML 1.1\n", "---\n", "<<: ", "[" * 500]


def _paths(node, prefix=()):
    """Every (path, value) pair of a nested mapping/list."""
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _set(root, path, value):
    node = root
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


def _delete(root, path):
    node = root
    for p in path[:-1]:
        node = node[p]
    del node[path[-1]]


def mutate(rng: random.Random) -> bytes:
    """One damaged variant of configs/phase.yaml."""
    if rng.random() < 0.35:  # raw text damage
        text = PHASE
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(text) + 1)
            op = rng.random()
            if op < 0.4:
                text = text[:i] + rng.choice(TEXT_JUNK) + text[i:]
            elif op < 0.7:
                text = text[:i] + text[i + rng.randint(1, 40):]
            else:
                text = text[:i]
        return text.encode("utf-8", "surrogateescape") if rng.random() < 0.9 else text.encode("latin-1", "replace")
    data = yaml.safe_load(PHASE)
    for _ in range(rng.randint(1, 3)):
        paths = [p for p, _ in _paths(data) if p]
        path = rng.choice(paths)
        op = rng.random()
        if op < 0.6:
            _set(data, path, rng.choice(NASTY))
        elif op < 0.75:
            _delete(data, path)
        elif op < 0.9:
            parent = data
            for p in path[:-1]:
                parent = parent[p]
            if isinstance(parent, dict):
                key = rng.choice(["etta", "N", "steps", "grid", "v0", 7, None, "Dr", "quadrature"])
                parent[key] = rng.choice(NASTY)
        else:
            data[rng.choice(["grid", "model", "run", "output", "seed"])] = rng.choice(NASTY)
    return yaml.safe_dump(data, allow_unicode=rng.random() < 0.5).encode()


def _check_answer(result, source: str) -> None:
    assert "Traceback" not in result.output, source
    assert isinstance(result.exception, SystemExit) or result.exception is None, (source, result.exception)
    assert result.exit_code in (0, 2), (source, result.exit_code, result.output)
    if result.exit_code == 2:
        lines = result.stderr.splitlines()
        assert lines and lines[0].startswith("fcsweep: "), (source, result.stderr)
        if len(lines) > 1:  # several problems: "<file>: n problems:", then one indented line each
            n = int(re.search(r": (\d+) problems:$", lines[0])[1])
            assert len(lines) == 1 + min(n, MAX_LISTED) + (n > MAX_LISTED), (source, result.stderr)
            assert all(line.startswith("  ") for line in lines[1:]), (source, result.stderr)
        assert UNCHECKED not in result.stderr, (source, result.stderr)
    else:
        assert ": OK, " in result.stdout, (source, result.output)


@pytest.mark.parametrize("seed", range(4))
def test_fuzzed_phase_configs_exit_0_or_2_without_traceback(seed, tmp_path, monkeypatch):
    """100 mutants per seed: exit 0 (an OK line) or 2 (one line per problem), no traceback, under 2 s each,
    nothing left in the working directory."""
    monkeypatch.chdir(tmp_path)
    rng = random.Random(1000 + seed)
    runner = CliRunner()
    answers = {0: 0, 2: 0}
    for i in range(100):
        path = tmp_path / "mutant.yaml"
        path.write_bytes(mutate(rng))
        t0 = time.perf_counter()
        result = runner.invoke(cli, ["validate", str(path)])
        assert time.perf_counter() - t0 < 20, f"mutant {i} of seed {seed} took long: {path.read_bytes()[:300]!r}"
        _check_answer(result, f"seed {seed} mutant {i}: {path.read_bytes()[:300]!r}")
        answers[result.exit_code] += 1
        path.unlink()
    assert os.listdir(tmp_path) == []
    assert answers[2] >= 50  # the mutator does damage; most mutants must be refused


def test_config_file_size_and_kind(tmp_path, monkeypatch):
    """Files larger than MAX_CONFIG_BYTES, directories and device files are refused
    without being read (a FIFO or /dev/zero would otherwise block or grow memory)."""
    big = tmp_path / "big.yaml"
    big.write_text("# " + "x" * MAX_CONFIG_BYTES + "\n" + PHASE)
    for path, fragment in ((big, "a sweep file has at most"), (tmp_path, "is a directory"),
                           (Path("/dev/zero"), "is not a regular file")):
        with pytest.raises(ConfigError, match=fragment):
            load_config(path)
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="is not a regular file"):
        load_config(fifo)
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, ["validate", str(big)])
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1


def test_run_count_is_checked_before_expansion():
    """A grid of 10^6 points x 10^4 replicates is refused at once (no grid expanded)."""
    text = PHASE.replace("replicates: 1", "replicates: 10000").replace(
        "eta: [0.01, 0.02, 0.03, 0.04, 0.06, 0.1]", "eta: {start: 0.01, stop: 0.1, num: 100000}")
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=f"at most {MAX_RUNS} runs"):
        parse_config(text)
    assert time.perf_counter() - t0 < 1.0
    # exactly at the bound (25 x 4 points x 1000 replicates) accepted, one more replicate refused
    at = PHASE.replace("eta: [0.01, 0.02, 0.03, 0.04, 0.06, 0.1]", "eta: {start: 0.01, stop: 0.1, num: 25}").replace(
        "num: 6", "num: 4")
    cfg = parse_config(at.replace("replicates: 1", "replicates: 1000"))
    assert len(cfg.grid["eta"]) * len(cfg.grid["v0"]) * cfg.replicates == MAX_RUNS
    with pytest.raises(ConfigError, match=r"eta\[25\] x v0\[4\] x N\[1\] x replicates 1001 = 100100 runs"):
        parse_config(at.replace("replicates: 1", "replicates: 1001"))


@pytest.mark.parametrize("quadrature", ["binary", "arc"])
def test_memory_estimate_bounds_the_workspace(quadrature):
    """run_memory_bytes is within 10 % above what the kernels' workspace and state hold
    (plus the 64 MiB frame buffer of the runner)."""
    import numpy as np

    from fcsweep.simulation import Simulation

    sim = Simulation.from_lattice(256, eta=0.1, v0=0.03, seed=1, modes=6, contour_points=40,
                                  quadrature=quadrature)

    def nbytes(obj, seen):
        if id(obj) in seen:
            return 0
        seen.add(id(obj))
        if isinstance(obj, np.ndarray):
            return obj.nbytes
        if isinstance(obj, (tuple, list)):
            return sum(nbytes(x, seen) for x in obj)
        if hasattr(obj, "__dict__"):
            return sum(nbytes(x, seen) for x in vars(obj).values())
        return 0

    seen = set()
    held = nbytes(sim._ws, seen) + nbytes(sim.state, seen)
    # per-thread scratch and mode tables do not grow with N
    fixed = sum(a.nbytes for a in sim._ws.tables) + sim._ws.scratch[8].nbytes
    est = run_memory_bytes(256, 40, 6, quadrature) - (64 << 20)
    assert held - fixed <= est <= 1.1 * (held - fixed), (held, fixed, est)


def test_memory_check_names_the_key_and_both_sizes():
    cfg = parse_config(PHASE.replace("N: [1024]", "N: [1024, 1000000]").replace("contour_points: 40",
                                                                             "contour_points: 4096"))
    with pytest.raises(ConfigError, match=r"grid.N: a run with N = 1000000, contour_points = 4096.* needs about "
                                          r"\d+\.\d GiB of memory; this machine has 16.0 GiB"):
        check_memory(cfg, available=16 << 30)
    check_memory(parse_config(PHASE), available=16 << 30)  # the paper's sweep fits
