"""Every code block of README.md and docs/*.md runs as written, or says why it cannot.

- A fenced block names its language: ``python`` and ``bash`` blocks are code, ``text``
  blocks are output or listings (not run); ``{name}`` fences are MyST directives of the
  documentation site (``{include}``, ``{toctree}``, ...), not code.
- A code block that cannot run here (installs packages, hours of CPU, a cluster) is
  preceded by ``<!-- not-run: REASON -->`` on the line before its fence; the reason is
  required.  Its ``fcsweep`` commands are still parsed by the real CLI, so a renamed
  command or option fails here.
- ``python`` blocks run in a fresh namespace in an empty directory.
- ``bash`` blocks run with ``bash -e`` (slow: they compute the demo), the blocks of one
  document in order in one scratch directory holding the repository's ``configs/``, with
  a private cost cache.
- The measured numbers the README and docs/*.md quote come from
  ``benchmarks/results/readme_numbers.json`` (written by ``benchmarks/readme_numbers.py``);
  the config comments' cost lines from the same file.  Compared here as text, never
  re-measured — except the size of the test suite, which is also compared with the tests
  pytest collects now (slow tests deselected, as ``python -m pytest`` does).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NUMBERS = ROOT / "benchmarks" / "results" / "readme_numbers.json"
CODE = ("python", "bash")
TEXT = ("text",)
DIRECTIVE = re.compile(r"^\{[\w-]+\}$")  # a MyST directive fence such as ```{include}
FENCE = re.compile(r"^```(\S*)(?:\s.*)?$")  # a directive fence has arguments: ```{include} PATH
NOT_RUN = re.compile(r"^<!--\s*not-run:(.*?)-->\s*$")


def _blocks(path: Path) -> list[dict]:
    lines = path.read_text().splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        start, lang = i, m.group(1)
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        prev = next((lines[k] for k in range(start - 1, -1, -1) if lines[k].strip()), "")
        skip = NOT_RUN.match(prev.strip())
        out.append({"doc": path.relative_to(ROOT).as_posix(), "line": start + 1, "lang": lang,
                    "code": "\n".join(lines[start + 1:j]), "not_run": skip.group(1).strip() if skip else None})
        i = j + 1
    return out


BLOCKS = [b for d in DOCS for b in _blocks(d)]


def _ids(blocks):
    return [f"{b['doc']}:{b['line']}" for b in blocks]


def test_every_block_names_its_language():
    bad = [f"{b['doc']}:{b['line']} ```{b['lang']}" for b in BLOCKS
           if b["lang"] not in CODE + TEXT and not DIRECTIVE.match(b["lang"])]
    assert not bad, f"fenced blocks must be ```python, ```bash or ```text: {bad}"


def test_every_not_run_block_gives_a_reason():
    marked = [b for b in BLOCKS if b["not_run"] is not None]
    assert marked, "expected some not-run blocks (install, cluster, hours of CPU)"
    for b in marked:
        assert len(b["not_run"]) >= 10, f"{b['doc']}:{b['line']}: say why the block is not run"
        assert b["lang"] in CODE, f"{b['doc']}:{b['line']}: only code blocks need a not-run marker"


# ------------------------------------------------------------------ fcsweep commands

_FCSWEEP = re.compile(r"(?:^|[\s(&;|])fcsweep\s+([^#&;|)\n]*)")


def _commands(code: str) -> list[list[str]]:
    """The argument lists of every ``fcsweep ...`` command in a bash block (continued lines
    joined, comments dropped)."""
    text = code.replace("\\\n", " ")
    out = []
    for line in text.splitlines():
        line = re.sub(r"\s#.*$", "", line)
        for m in _FCSWEEP.finditer(line):
            out.append(shlex.split(m.group(1)))
    return out


BASH = [b for b in BLOCKS if b["lang"] == "bash"]


@pytest.mark.parametrize("block", BASH, ids=_ids(BASH))
def test_fcsweep_commands_parse(block):
    """Commands and options exist and take the values given (nothing is executed)."""
    from fcsweep.cli import cli

    for args in _commands(block["code"]):
        if not args or args[0] in ("--help", "-h"):
            continue
        ctx = click.Context(cli, info_name="fcsweep")
        cmd = cli.get_command(ctx, args[0])
        assert cmd is not None, f"{block['doc']}:{block['line']}: no command `fcsweep {args[0]}`"
        try:
            cmd.make_context(args[0], args[1:], parent=ctx)
        except click.UsageError as exc:
            pytest.fail(f"{block['doc']}:{block['line']}: `fcsweep {' '.join(args)}`: {exc.format_message()}")


# ------------------------------------------------------------------ running the blocks

PYTHON = [b for b in BLOCKS if b["lang"] == "python" and b["not_run"] is None]


@pytest.mark.parametrize("block", PYTHON, ids=_ids(PYTHON))
def test_python_block_runs(block, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(block["code"], f"{block['doc']}:{block['line']}", "exec"), {"__name__": "__docs__"})


RUN_BASH = [b for b in BASH if b["not_run"] is None]
_SCRATCH: dict[str, Path] = {}


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    def get(doc: str) -> Path:
        if doc not in _SCRATCH:
            d = tmp_path_factory.mktemp(doc.replace("/", "_").replace(".", "_"))
            (d / "configs").symlink_to(ROOT / "configs")
            _SCRATCH[doc] = d
        return _SCRATCH[doc]

    return get


@pytest.mark.slow
@pytest.mark.parametrize("block", RUN_BASH, ids=_ids(RUN_BASH))
def test_bash_block_runs(block, scratch):
    cwd = scratch(block["doc"])
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "FCSWEEP_COST_CACHE": str(cwd / ".cost-cache"), "MPLBACKEND": "Agg"}
    r = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block["code"]], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=900)
    where = f"{block['doc']}:{block['line']}"
    assert r.returncode == 0, f"{where} exit {r.returncode}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"


def test_blocks_that_run_are_not_heavy():
    """Runnable bash blocks stay on the demo or on commands that only read or time a config."""
    heavy = re.compile(r"fcsweep\s+(simulate|refine|analyze)\s+configs/(?!.*--dry-run)")
    for b in RUN_BASH:
        for line in b["code"].splitlines():
            assert not heavy.search(line.split("#")[0]), f"{b['doc']}:{b['line']}: `{line}` computes a real sweep"


# ------------------------------------------------------------------ quoted numbers


def _numbers() -> dict:
    return json.loads(NUMBERS.read_text())


def _quoting_text() -> str:
    """README.md and the site's pages (docs/performance.md holds the timings)."""
    return "\n".join(d.read_text() for d in DOCS)


def test_readme_quotes_the_measured_numbers():
    """Each number the README and the docs give for the demo, the analysis and the test
    suite is the one in readme_numbers.json (its ``quotes``: a regex with one group, and
    the text that group must read)."""
    readme = _quoting_text()
    data = _numbers()
    assert data["quotes"], "readme_numbers.json lists no quotes"
    for q in data["quotes"]:
        found = re.findall(q["pattern"], readme)
        assert found, f"README no longer contains {q['pattern']!r} ({q['key']})"
        assert all(f == q["text"] for f in found), f"README says {found} for {q['key']}; measured: {q['text']}"


def test_config_cost_lines_match_the_cost_model_output():
    data = _numbers()["configs"]
    assert data
    for name, entry in data.items():
        text = (ROOT / "configs" / name).read_text()
        lines = [ln for ln in text.splitlines() if ln.startswith("# cost:")]
        assert lines == [entry["comment"]], f"configs/{name}: run benchmarks/readme_numbers.py --configs"

