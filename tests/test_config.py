"""Sweep config: validation, grid expansion, run ids and seeds; the bad-config corpus."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import ConfigError, builtin_demo_path, load_config, parse_config, run_id_of, seed_of

BAD = Path(__file__).parent / "data" / "bad_configs"
ROOT = Path(__file__).resolve().parents[1]

GOOD = """
output: out
seed: 7
replicates: 2
grid:
  eta: [0.01, 0.1]
  v0: {start: 0.01, stop: 0.05, num: 3}
model:
  N: 16
run: {steps: 100, sample_every: 10, checkpoint_every: 50}
"""


def test_grid_expansion_order_and_defaults():
    cfg = parse_config(GOOD)
    runs = cfg.runs()
    # 2 eta x 3 v0 x 2 replicates; last grid key fastest, replicate innermost
    assert len(runs) == 12
    assert [r.index for r in runs] == list(range(12))
    assert [(r.params["eta"], r.params["v0"], r.replicate) for r in runs[:4]] == [
        (0.01, 0.01, 0), (0.01, 0.01, 1), (0.01, 0.03, 0), (0.01, 0.03, 1)]
    assert np.allclose(cfg.grid["v0"], [0.01, 0.03, 0.05])
    p = runs[0].params
    # defaults of docs/model.md filled in
    assert (p["Dr"], p["density"], p["dt"], p["modes"], p["contour_points"], p["quadrature"]) == (
        0.01, 0.95, 5e-3, 6, 40, "arc")
    assert cfg.swept == ["eta", "v0"] and runs[0].swept == ("eta", "v0")
    assert cfg.run.n_frames == 11 and cfg.run.transient == 0.2
    assert cfg.output == Path("out")
    assert cfg.run_dir(runs[0].run_id) == Path("out") / "runs" / runs[0].run_id


def test_run_ids_canonical_stable_and_distinct():
    a = parse_config(GOOD.replace("eta: [0.01, 0.1]", "eta: [1, 2]"))
    b = parse_config(GOOD.replace("eta: [0.01, 0.1]", "eta: [1.0, 2.0]"))
    assert [r.run_id for r in a.runs()] == [r.run_id for r in b.runs()]
    ids = [r.run_id for r in parse_config(GOOD).runs()]
    assert len(set(ids)) == len(ids) and all(len(i) == 12 for i in ids)
    # the base seed does not change ids but changes every run's seed
    c = parse_config(GOOD.replace("seed: 7", "seed: 8"))
    assert [r.run_id for r in c.runs()] == ids
    s7 = [r.seed for r in parse_config(GOOD).runs()]
    s8 = [r.seed for r in c.runs()]
    assert len(set(s7)) == len(s7) and not set(s7) & set(s8)
    assert all(0 <= s < 2**63 for s in s7)
    # deterministic function of (base seed, id); a fixed value guards against silent change
    rid = run_id_of({"N": 16, "eta": 0.1, "v0": 0.03}, 0)
    assert rid == run_id_of({"N": 16.0, "eta": 0.1, "v0": 0.03, "seed": 99}, 0)
    assert seed_of(7, rid) == seed_of(7, rid) != seed_of(7, run_id_of({"N": 16, "eta": 0.1, "v0": 0.03}, 1))


def test_any_parameter_may_be_swept_and_log_ranges():
    cfg = parse_config(
        """
output: o
grid:
  N: [16, 36]
  dt: {start: 0.001, stop: 0.1, num: 3, log: true}
  quadrature: [binary, arc]
  modes: [0, 4]
  contour_points: {start: 20, stop: 40, num: 3}
model: {eta: 0.1, v0: 0.03}
run: {steps: 10, sample_every: 5}
"""
    )
    assert np.allclose(cfg.grid["dt"], [0.001, 0.01, 0.1])
    assert cfg.grid["contour_points"] == (20, 30, 40)
    assert len(cfg.runs()) == 2 * 3 * 2 * 2 * 3
    assert cfg.run.checkpoint_every == 10  # default: only at the end
    assert all(isinstance(r.params["N"], int) for r in cfg.runs())


def test_output_mapping_selects_fields():
    cfg = parse_config(GOOD.replace("output: out", "output: {dir: o, fields: [theta], compression: lzf}"))
    assert cfg.store.fields == ("position", "image", "theta")  # position+image always
    assert cfg.store.compression == "lzf"


def test_builtin_demo_is_configs_smoke():
    assert builtin_demo_path().read_text() == (ROOT / "configs" / "smoke.yaml").read_text()
    cfg = load_config(builtin_demo_path())
    assert cfg.output == Path("fcsweep-demo") and len(cfg.runs()) == 4


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "configs").glob("*.yaml")))
def test_shipped_configs_validate(name):
    cfg = load_config(ROOT / "configs" / name)
    assert len(cfg.runs()) >= 1


def test_missing_file_is_config_error(tmp_path):
    with pytest.raises(ConfigError, match="cannot read config file"):
        load_config(tmp_path / "nope.yaml")


BAD_FILES = sorted(BAD.glob("*.yaml"))


def _expected(path: Path) -> str:
    """The ``# expect: ...`` first line (read as bytes: some files are not UTF-8 on purpose)."""
    first = path.read_bytes().split(b"\n", 1)[0].decode("utf-8")
    assert first.startswith("# expect: "), path
    return first[len("# expect: "):]


def test_bad_corpus_is_large_and_distinct():
    assert len(BAD_FILES) >= 60
    expects = [_expected(f) for f in BAD_FILES]
    assert len(set(expects)) == len(expects)


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.stem)
@pytest.mark.parametrize("command", ["validate", "simulate"])
def test_bad_config_rejected_by_cli(path, command, tmp_path, monkeypatch):
    """Each bad file: exit code 2, one line on stderr containing the expected fragment (the
    key or the file, the value, what is allowed), no traceback, nothing written."""
    expected = _expected(path)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, [command, str(path)])
    assert result.exit_code == 2, result.output
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("fcsweep: "), result.stderr
    assert expected in lines[0], lines[0]
    assert "Traceback" not in result.output and isinstance(result.exception, SystemExit)
    assert os.listdir(tmp_path) == []
