"""Sweep config: validation, grid expansion, run ids and seeds; the bad-config corpus."""

from __future__ import annotations

import os
import re
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


# ------------------------------------------------- numbers as YAML 1.2 and Python write them


def test_scientific_notation_loads_in_model_run_and_grid():
    """PyYAML's YAML 1.1 reads 5e-3 as a string; the loader reads it as Python float() does."""
    text = GOOD.replace("N: 16", "N: 16\n  dt: 5e-3\n  Dr: 1E-2\n  R0: 1.0e0").replace(
        "eta: [0.01, 0.1]", "eta: [1e-2, .1e0]").replace(
        "run: {steps: 100, sample_every: 10, checkpoint_every: 50}",
        "run: {steps: 1e2, sample_every: 1.0e1, checkpoint_every: 5e+1, transient: 2E-1}")
    cfg = parse_config(text)
    assert (cfg.model["dt"], cfg.model["Dr"], cfg.model["R0"]) == (0.005, 0.01, 1.0)
    assert cfg.grid["eta"] == (0.01, 0.1)
    assert (cfg.run.steps, cfg.run.sample_every, cfg.run.checkpoint_every, cfg.run.transient) == (100, 10, 50, 0.2)
    assert all(isinstance(x, int) for x in (cfg.run.steps, cfg.run.sample_every, cfg.run.checkpoint_every))
    # the same runs as the plain spelling
    assert [r.run_id for r in cfg.runs()] == [r.run_id for r in parse_config(
        GOOD.replace("N: 16", "N: 16\n  dt: 0.005\n  Dr: 0.01\n  R0: 1.0")).runs()]
    # ranges too
    cfg = parse_config(GOOD.replace("v0: {start: 0.01, stop: 0.05, num: 3}", "v0: {start: 1e-2, stop: 5E-2, num: 3e0}"))
    assert cfg.grid["v0"] == (0.01, 0.03, 0.05)


@pytest.mark.parametrize("text,value", [
    ("5e-3", 0.005), ("1E-2", 0.01), ("2.0e3", 2000.0), ("-1e-3", -0.001), ("+.5e1", 5.0), ("5.e1", 50.0),
    ("1_000e-3", 1.0), ("1.5", 1.5), ("1_000", 1000), ("0o17", 15), ("017", 17), ("0x1f", 31), (".inf", float("inf")),
    ("1e", "1e"), ("e3", "e3"), ("1__0e3", "1__0e3"), ("1_e3", "1_e3"), ("1e-3.5", "1e-3.5"), ("'1e3'", "1e3"),
])
def test_number_syntax_is_python_and_yaml_1_2(text, value):
    """Exactly the exponent forms float() accepts become floats ('_' only between digits);
    017 is 17 as in YAML 1.2 (not 1.1's octal 15); what YAML 1.1 read as a number reads as before."""
    import yaml

    from fcsweep.config import UniqueKeyLoader

    got = yaml.load(f"a: {text}", Loader=UniqueKeyLoader)["a"]
    assert got == value and type(got) is type(value)


def test_integral_floats_accepted_for_integer_keys_others_refused():
    cfg = parse_config(GOOD.replace("N: 16", "N: 1.6e1\n  modes: 4.0\n  contour_points: 4e1").replace(
        "seed: 7", "seed: 7e0").replace("replicates: 2", "replicates: 2.0"))
    assert (cfg.model["N"], cfg.model["modes"], cfg.model["contour_points"], cfg.seed, cfg.replicates) == (
        16, 4, 40, 7, 2)
    assert all(isinstance(r.params["N"], int) for r in cfg.runs())
    for old, new, message in [
        ("steps: 100", "steps: 1.005e2", "run.steps = 100.5 must be an integer; allowed 1 <= steps <= 1000000000000"),
        ("sample_every: 10", "sample_every: 2.5", "run.sample_every = 2.5 must be an integer; allowed 1 <= "),
        ("N: 16", "N: 16.5", "model.N = 16.5 must be an integer; allowed N = n*n with n even, 4 <= N <= 1000000"),
        ("replicates: 2", "replicates: 1.5e0", "replicates = 1.5 must be an integer; allowed 1 <= replicates <= "),
    ]:
        with pytest.raises(ConfigError, match="^<string>: " + re.escape(message)):
            parse_config(GOOD.replace(old, new))


@pytest.mark.parametrize("old,new,message", [
    ("N: 16", "N: 16\n  dt: abc", "model.dt = 'abc' must be a number; allowed 1e-06 <= dt <= 1"),
    ("N: 16", "N: 16\n  density: [0.5]", "model.density = [0.5] must be a number; allowed 1e-06 <= density < 1"),
    ("N: 16", "N: 16\n  modes: six", "model.modes = 'six' must be an integer; allowed 0 (rigid discs) or 2..32"),
    ("N: 16", "N: sixteen", "model.N = 'sixteen' must be an integer; allowed N = n*n with n even, 4 <= N <= 1000000"),
    ("eta: [0.01, 0.1]", "eta: [0.01, x]", "grid.eta = 'x' must be a number; allowed 0 <= eta <= 1000"),
    ("start: 0.01", "start: low", "grid.v0.start = 'low' must be a number; allowed 0 <= v0 <= 1000"),
    ("N: 16", "N: 16\n  dt: .nan", "model.dt = nan must be a finite number; allowed 1e-06 <= dt <= 1"),
    ("seed: 7", "seed: x", "seed = 'x' must be an integer; allowed 0 <= seed < 2**63"),
    ("checkpoint_every: 50", "checkpoint_every: 50, transient: x",
     "run.transient = 'x' must be a number; allowed 0 <= transient < 1"),
])
def test_type_errors_name_the_allowed_range(old, new, message):
    with pytest.raises(ConfigError, match="^<string>: " + re.escape(message) + "$"):
        parse_config(GOOD.replace(old, new))


def test_grid_values_checked_against_the_model_ranges():
    from fcsweep.config import PARAM_RANGES

    for name, (_lo, hi) in PARAM_RANGES.items():
        if name in ("N", "contour_points", "modes"):
            continue
        over = GOOD.replace("eta: [0.01, 0.1]", f"eta: [0.01, 0.1]\n  {name}: [{hi * 10:g}]")
        if name == "eta":
            over = GOOD.replace("eta: [0.01, 0.1]", f"eta: [0.01, {hi * 10:g}]")
        if name == "v0":
            over = GOOD.replace("v0: {start: 0.01, stop: 0.05, num: 3}", f"v0: [{hi * 10:g}]")
        with pytest.raises(ConfigError, match=re.escape(f"grid.{name} = {hi * 10:g}") + ".* is out of range"):
            parse_config(over)


# -------------------------------------------------------------------- did you mean


@pytest.mark.parametrize("old,new,fragment", [
    ("v0: {", "vo: {", "unknown key in grid: 'vo'; did you mean 'v0'?"),
    ("eta: [", "Eta: [", "unknown key in grid: 'Eta'; did you mean 'eta'?"),
    ("N: 16", "N: 16\n  dr: 0.1", "unknown key in model: 'dr'; did you mean 'Dr'?"),
    ("N: 16", "N: 16\n  RO: 1", "unknown key in model: 'RO'; did you mean 'R0'?"),
    ("N: 16", "N: 16\n  tD: 0.1", "unknown key in model: 'tD'; did you mean 'dt'?"),
    ("seed: 7", "sed: 7", "unknown key 'sed'; did you mean 'seed'?"),
    ("stop: 0.05", "stpo: 0.05", "unknown key in grid.v0: 'stpo'; did you mean 'stop'?"),
    ("sample_every: 10", "sampleevery: 10", "unknown key in run: 'sampleevery'; did you mean 'sample_every'?"),
    ("output: out", "output: {dir: out, compresion: lzf}", "unknown key in output: 'compresion'; did you mean "
                                                            "'compression'?"),
])
def test_did_you_mean_at_every_level(old, new, fragment):
    with pytest.raises(ConfigError) as info:
        parse_config(GOOD.replace(old, new))
    assert str(info.value) == f"<string>: {fragment} (allowed: " + str(info.value).split("(allowed: ")[1]


def test_a_misspelled_key_is_not_also_reported_missing():
    """`vo` suggests `v0`: no second message that v0 is missing; likewise a misspelled
    section, range key or run key."""
    for old, new in [("v0: {", "vo: {"), ("run:", "rnu:"), ("stop: 0.05", "stpo: 0.05"), ("steps: 100", "step: 100")]:
        with pytest.raises(ConfigError) as info:
            parse_config(GOOD.replace(old, new))
        assert len(info.value.problems) == 1 and "did you mean" in str(info.value), str(info.value)


# --------------------------------------------------------------- all problems at once


MANY = """
output: out
seed: -3
gird: {}
grid:
  eta: [0.01, abc]
  vo: [0.03]
  dt: {start: 0, stop: 0.01, num: 2.5}
model:
  N: 25
  density: 1.2
  quadrature: simpson
run: {steps: 105, sample_every: 10, checkpoint_every: 55, transient: 1.5, extra: 1}
"""


def test_all_problems_of_a_file_reported_at_once(tmp_path, monkeypatch):
    expected = [
        "unknown key 'gird'; did you mean 'grid'?",
        "seed = -3 must be an integer >= 0",
        "unknown key in grid: 'vo'; did you mean 'v0'?",
        "grid.eta = 'abc' must be a number; allowed 0 <= eta <= 1000",
        "grid.dt.num = 2.5 must be an integer; allowed 1 <= num <= 100000",
        "model.N = 25: N must be n*n with n even",
        "model.density = 1.2 is out of range; density must lie in (0, 1)",
        "model.quadrature = 'simpson' is not allowed; choose one of ['binary', 'linear', 'arc']",
        "unknown key in run: 'extra'",
        "run.steps = 105 is not a multiple of run.sample_every = 10",
        "run.checkpoint_every = 55 is not a multiple of run.sample_every = 10",
        "run.transient = 1.5 is out of range; allowed 0 <= transient < 1",
    ]
    with pytest.raises(ConfigError) as info:
        parse_config(MANY)
    problems = info.value.problems
    assert len(problems) == len(expected), problems
    for fragment, problem in zip(expected, problems):
        assert problem.startswith(fragment), (fragment, problem)
    lines = str(info.value).splitlines()
    assert lines[0] == f"<string>: {len(expected)} problems:"
    assert [line[2:] for line in lines[1:]] == list(problems)
    # the command line: exit 2, the count first, one line per problem, nothing written
    path = tmp_path / "many.yaml"
    path.write_text(MANY)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, ["validate", str(path)])
    assert result.exit_code == 2 and result.stdout == ""
    out = result.stderr.splitlines()
    assert out[0] == f"fcsweep: invalid config: {path}: {len(expected)} problems:"
    assert len(out) == 1 + len(expected) and all(line.startswith("  ") for line in out[1:])
    assert os.listdir(tmp_path) == ["many.yaml"]


def test_one_problem_keeps_the_one_line_message():
    with pytest.raises(ConfigError) as info:
        parse_config(GOOD.replace("N: 16", "N: 25"))
    assert str(info.value).startswith("<string>: model.N = 25: N must be n*n") and "\n" not in str(info.value)
    assert len(info.value.problems) == 1


def test_many_problems_are_listed_up_to_a_limit():
    from fcsweep.config import MAX_LISTED

    bad = ", ".join(f"-{k + 1}" for k in range(MAX_LISTED + 5))
    with pytest.raises(ConfigError) as info:
        parse_config(GOOD.replace("eta: [0.01, 0.1]", f"eta: [{bad}]"))
    lines = str(info.value).splitlines()
    assert lines[0] == f"<string>: {MAX_LISTED + 5} problems:"
    assert len(lines) == MAX_LISTED + 2 and lines[-1] == "  ... and 5 more"


def test_run_checks_report_every_kind_of_problem():
    """check_runnable lists the step length, rotational step and tension problems together
    (the first grid point of each kind)."""
    from fcsweep.config import check_runnable

    cfg = parse_config(GOOD.replace("N: 16", "N: 16\n  Dr: 100\n  dt: 0.02").replace(
        "eta: [0.01, 0.1]", "eta: [10, 20]").replace("v0: {start: 0.01, stop: 0.05, num: 3}", "v0: [20, 30]"))
    with pytest.raises(ConfigError) as info:
        check_runnable(cfg)
    problems = info.value.problems
    assert len(problems) == 3, problems
    assert problems[0].startswith("model.dt: dt = 0.02 is too large for eta = 10")
    assert problems[1].startswith("grid.v0 = 20 with dt = 0.02")
    assert problems[2].startswith("model.Dr = 100 with dt = 0.02 gives Dr*dt = 2")
    assert str(info.value).splitlines()[0] == "<string>: 3 problems:"


# ----------------------------------------------------------------------- JSON Schema


def _yaml(text: str):
    import yaml

    from fcsweep.config import UniqueKeyLoader

    return yaml.load(text, Loader=UniqueKeyLoader)


def test_schema_command_prints_the_schema_of_the_range_table():
    import json

    from fcsweep.config import PARAM_RANGES, json_schema

    result = CliRunner().invoke(cli, ["schema"])
    assert result.exit_code == 0
    schema = json.loads(result.stdout)
    assert schema == json.loads(json.dumps(json_schema()))
    model = schema["properties"]["model"]["anyOf"][0]["properties"]
    for name, (lo, hi) in PARAM_RANGES.items():
        assert model[name]["minimum"] == lo
        assert model[name].get("maximum", model[name].get("exclusiveMaximum")) == hi
    assert model["quadrature"]["enum"] == ["binary", "linear", "arc"]
    assert set(schema["properties"]["grid"]["properties"]) == set(model)


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "configs").glob("*.yaml")))
def test_shipped_configs_match_the_json_schema(name):
    jsonschema = pytest.importorskip("jsonschema")
    from fcsweep.config import json_schema

    jsonschema.Draft7Validator.check_schema(json_schema())
    jsonschema.validate(_yaml((ROOT / "configs" / name).read_text()), json_schema())


@pytest.mark.parametrize("old,new", [
    ("v0: {", "vo: {"), ("N: 16", "N: 16\n  dt: 2"), ("N: 16", "N: 16\n  modes: 1"), ("seed: 7", "seed: -1"),
    ("N: 16", "N: 16\n  quadrature: simpson"), ("sample_every: 10", "sample_every: 2.5"), ("num: 3", "num: 0"),
    ("output: out", "output: {fields: [theta]}"), ("eta: [0.01, 0.1]", "eta: []"),
])
def test_json_schema_refuses_what_validation_refuses(old, new):
    jsonschema = pytest.importorskip("jsonschema")
    from fcsweep.config import json_schema

    text = GOOD.replace(old, new)
    jsonschema.validate(_yaml(GOOD), json_schema())
    with pytest.raises(ConfigError):
        parse_config(text)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(_yaml(text), json_schema())
