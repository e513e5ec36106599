"""The declared tables of model parameters and observables drive validation, the engine's
parameters, the NetCDF metadata and the docs (issue 27, item 3)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from fcsweep.config import MODEL_DEFAULTS, ConfigError, json_schema, parse_config
from fcsweep.model.observables import CURVES, OBSERVABLES, RUN_SCALARS, UNTIL_OBSERVABLES
from fcsweep.model.observables import markdown_table as observables_table
from fcsweep.model.parameters import DEFAULTS, PARAMETERS
from fcsweep.model.parameters import markdown_table as parameters_table
from fcsweep.simulation import SimParams

ROOT = Path(__file__).resolve().parents[1]

BASE = """
output: {out}
grid: {{N: [16]}}
model: {{{model}}}
run: {{steps: 10, sample_every: 5}}
"""


def _sweep(out, **model) -> str:
    values = {"eta": 0.1, "v0": 0.01, **model}
    return BASE.format(out=out, model=", ".join(f"{k}: {v!r}" for k, v in values.items()))


def _generated(doc: str) -> str:
    text = (ROOT / doc).read_text()
    m = re.search(r"<!-- generated from [^\n]*-->\n(.*?)<!-- end of generated table -->", text, re.S)
    assert m, f"{doc} has no generated table"
    return m.group(1)


def test_docs_tables_are_the_generated_ones():
    assert _generated("configs/README.md") == parameters_table()
    assert _generated("results_schema.md") == observables_table()


def test_simparams_fields_and_defaults_are_the_table():
    fields = [f.name for f in dataclasses.fields(SimParams)]
    assert fields == ["N", "eta", "v0", "seed"] + list(PARAMETERS)[3:]
    for f in dataclasses.fields(SimParams):
        if f.name in PARAMETERS and PARAMETERS[f.name].default is not None:
            assert f.default == PARAMETERS[f.name].default
    assert MODEL_DEFAULTS == DEFAULTS


@pytest.mark.parametrize("name", [n for n, p in PARAMETERS.items() if p.type is float])
def test_each_float_range_is_enforced_by_config_schema_and_engine(name, tmp_path):
    """Just beyond the declared upper bound the config names the key and the range; the JSON
    Schema carries the same bounds; the engine refuses what breaks the physical sign."""
    p = PARAMETERS[name]
    lo, hi = p.range
    bad = hi * 1.5
    with pytest.raises(ConfigError, match=rf"model\.{name} = .* is out of range; (allowed|{name} must)"):
        parse_config(_sweep(tmp_path, **{name: bad}))
    schema = json_schema()["properties"]["model"]["anyOf"][0]["properties"][name]
    assert schema["minimum"] == lo
    assert schema.get("maximum", schema.get("exclusiveMaximum")) == hi
    if p.sign:
        below = -1.0 if p.sign == ">= 0" else 0.0
        with pytest.raises(ValueError, match=rf"{name} = .* is out of range; {name} must (be|lie)"):
            SimParams(**{"N": 16, "eta": 0.1, "v0": 0.01, "seed": 1, name: below})


def test_observables_table_covers_pipeline_aggregate_and_until():
    from fcsweep.results.aggregate import META, SCALAR_VARS
    from fcsweep.results.analyze import SCALARS

    assert set(SCALARS) == set(RUN_SCALARS) | {n for n, o in OBSERVABLES.items() if o.kind == "label"}
    assert SCALAR_VARS == RUN_SCALARS
    for name in OBSERVABLES:
        assert META[name][0] == OBSERVABLES[name].long_name
    for name in UNTIL_OBSERVABLES:  # the until check reads <name>_err
        assert name in RUN_SCALARS and f"{name}_err" in RUN_SCALARS
    for axis in CURVES.values():
        assert OBSERVABLES[axis].kind == "coord"
    text = (ROOT / "configs" / "README.md").read_text()
    listed = re.search(r"Observables `rel_error` accepts: (.*?)\. ", text, re.S).group(1)
    assert re.findall(r"`(\w+)`", listed) == list(UNTIL_OBSERVABLES)


def test_unknown_until_observable_names_the_allowed_ones(tmp_path):
    until = "until: {check_every: 10, rel_error: {D_ef: 0.1}}"
    run = "run: {steps: 10, sample_every: 5}"
    text = _sweep(tmp_path).replace(run, run[:-1] + f", {until}}}")
    with pytest.raises(ConfigError, match="did you mean 'D_eff'") as exc:
        parse_config(text)
    for name in UNTIL_OBSERVABLES:
        assert name in str(exc.value)


def test_status_flags_come_from_the_run_states_and_the_schema_lists_them():
    """Every run state of io.schema has its own flag (interrupted and corrupt too), each flag
    is one results_schema.md names with its code, and nothing else is a flag."""
    from fcsweep.io.schema import DONE, STATUSES
    from fcsweep.results.aggregate import STATUS_FLAGS

    words = set(STATUS_FLAGS.values())
    assert set(STATUSES) - {DONE} <= words and DONE not in words
    assert words - set(STATUSES) == {"analysed", "not_analysed", "analysis_failed", "missing"}
    text = (ROOT / "results_schema.md").read_text()
    listed = re.search(r"`status` (0 analysed.*?):", text, re.S).group(1)
    assert listed == ", ".join(f"{c} {w}" for c, w in sorted(STATUS_FLAGS.items()))


def test_fit_groups_of_the_table():
    """The KTHNY fit keys and the finite-size collapse variables are groups of the table,
    each a value and its error (and the collapse's quality)."""
    from fcsweep.model.observables import KTHNY_FITS, group

    assert KTHNY_FITS and all(OBSERVABLES[n].kind == "run" for n in KTHNY_FITS)
    assert {n for n in KTHNY_FITS if not n.endswith("_err")} == {n[:-4] for n in KTHNY_FITS if n.endswith("_err")}
    for g in ("fss", "fss_shuffled"):
        names = group(g)
        assert f"{g}_quality" in names and all(OBSERVABLES[n].kind == "dataset" for n in names)
        values = {n for n in names if not n.endswith(("_err", "_quality"))}
        assert values == {n[:-4] for n in names if n.endswith("_err")} == {f"{g}_rho_c", f"{g}_nu", f"{g}_beta"}
