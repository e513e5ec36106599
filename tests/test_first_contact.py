"""What a newcomer meets: commands in workflow order, the output directory named, exit 1
with a message (and nothing written) where there is nothing to work on, a dry run that
writes nothing, advice that fits the situation, status columns for the analysis, batch
log lines with rate and ETA, and a movie."""

from __future__ import annotations

import io
import os
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.sweep.bench import StepCost, run_cpu_seconds, run_seconds, wall_time
from fcsweep.sweep.progress import Progress

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ROOT / "configs" / "smoke.yaml"


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    """The smoke sweep (identical to the demo), simulated into a fresh directory."""
    out = tmp_path_factory.mktemp("first") / "sweep"
    r = invoke("simulate", SMOKE, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    return out


def test_help_lists_commands_in_workflow_order():
    r = invoke("--help")
    assert r.exit_code == 0
    listed = [line.split()[0] for line in r.output.split("Commands:")[1].strip().splitlines()]
    order = ["validate", "bench", "simulate", "status", "analyze", "aggregate", "plot"]
    assert [c for c in listed if c in order] == order
    assert {"movie", "compile", "list-runs"} <= set(listed)


@pytest.mark.parametrize("command", ["status", "analyze", "aggregate", "plot"])
def test_results_commands_on_an_empty_directory_exit_1_and_write_nothing(tmp_path, command):
    out = tmp_path / "nowhere"
    r = invoke(command, SMOKE, "-o", out)
    assert r.exit_code == 1, r.output
    assert f"output directory {out.resolve()}" in r.output
    last = r.output.strip().splitlines()[-1]
    assert last.startswith("fcsweep: nothing") and str(out.resolve()) in last
    assert not out.exists()


def test_results_commands_need_the_previous_step(done, tmp_path):
    """Simulated but not analysed: aggregate and plot exit 1 naming the missing step and
    create neither phase_diagram.nc nor figures; analyze then works."""
    copy = tmp_path / "copy"
    shutil.copytree(done, copy)
    for command in ("aggregate", "plot"):
        r = invoke(command, SMOKE, "-o", copy)
        assert r.exit_code == 1 and "fcsweep analyze" in r.output, r.output
    assert not (copy / "phase_diagram.nc").exists() and not (copy / "figures").exists()
    r = invoke("plot", SMOKE, "-o", copy, "--run", "9")
    assert r.exit_code == 2 and "index 0..3" in r.output


def test_dry_run_writes_nothing_and_says_what_would_happen(done, tmp_path):
    fresh = tmp_path / "fresh"
    r = invoke("simulate", SMOKE, "-o", fresh, "--dry-run")
    assert r.exit_code == 0, r.output
    assert "4 to start, 0 to resume, 0 to skip" in r.output
    assert "estimated" in r.output and "of CPU" in r.output and "wall time" in r.output
    assert not fresh.exists()
    before = sorted(p.name for p in done.rglob("*"))
    r = invoke("simulate", SMOKE, "-o", done, "--dry-run")
    assert r.exit_code == 0 and "0 to start, 0 to resume, 4 to skip" in r.output, r.output
    assert sorted(p.name for p in done.rglob("*")) == before


def test_changed_run_length_extends_and_changed_sampling_is_advised_force(done, tmp_path):
    """More steps: the dry run and status say the done runs will be extended. Another
    sample_every: refused, with --force (never --retry-failed) as the advice."""
    longer = tmp_path / "longer.yaml"
    longer.write_text(SMOKE.read_text().replace("steps: 100000", "steps: 200000"))
    r = invoke("simulate", longer, "-o", done, "--dry-run")
    assert r.exit_code == 0 and "4 to extend" in r.output and "to 200000 steps" in r.output, r.output
    r = invoke("status", longer, "-o", done)
    assert "will be extended: to 200000 steps" in r.output, r.output
    resampled = tmp_path / "resampled.yaml"
    resampled.write_text(SMOKE.read_text().replace("sample_every: 400", "sample_every: 500"))
    r = invoke("simulate", resampled, "-o", done, "--dry-run")
    assert r.exit_code == 0 and "4 blocked" in r.output and "sample_every 400 -> 500" in r.output, r.output
    assert "--force" in r.output and "--retry-failed" not in r.output
    r = invoke("status", resampled, "-o", done)
    assert "computed with other run settings (sample_every 400 -> 500)" in r.output
    assert "--force" in r.output and "--retry-failed" not in r.output
    r = invoke("simulate", resampled, "-o", done, "-q")
    assert r.exit_code == 1
    assert "--force" in r.output and "--retry-failed" not in r.output


def test_status_says_which_runs_are_analysed_and_which_analyses_are_stale(done, tmp_path):
    pytest.importorskip("freud")
    copy = tmp_path / "copy"
    shutil.copytree(done, copy)
    r = invoke("status", SMOKE, "-o", copy)
    assert "analysed" in r.output.splitlines()[2] and "fcsweep analyze" in r.output
    assert invoke("analyze", SMOKE, "-o", copy).exit_code == 0
    r = invoke("status", SMOKE, "-o", copy, "--json")
    import json

    rows = json.loads(r.output)
    assert [row["analysis"] for row in rows] == ["yes"] * 4
    traj = next(copy.glob("runs/*/trajectory.h5"))
    from fcsweep.results.analyze import settings_with
    from fcsweep.sweep.status import analysis_state

    now = settings_with(transient=0.2)
    assert analysis_state(traj.parent, 0.2, now) == "yes"
    assert analysis_state(traj.parent, 0.2, {**now, "fit_window": [0.2, 0.5]}) == "stale"  # analyze would redo it
    assert analysis_state(traj.parent, 0.3) == "stale"  # another transient
    later = traj.with_name("analysis.h5").stat().st_mtime + 10
    os.utime(traj, (later, later))  # the trajectory was recomputed after its analysis
    r = invoke("status", SMOKE, "-o", copy)
    assert " stale " in r.output and "fcsweep analyze" in r.output and "--force" in r.output


def test_movie_of_a_tiny_trajectory(done, tmp_path):
    iio = pytest.importorskip("imageio.v2")
    pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "m.mp4"
    r = invoke("movie", "0", SMOKE, "-o", done, "--every", "10", "--dpi", "50", "--out", out)
    assert r.exit_code == 0, r.output
    reader = iio.get_reader(out)
    frames = sum(1 for _ in reader)
    assert frames == 26  # 251 recorded frames, every 10th
    h, w = reader.get_data(0).shape[:2]
    assert h % 16 == 0 and w % 16 == 0  # padded for H.264
    r = invoke("movie", "0", SMOKE, "-o", tmp_path / "empty")
    assert r.exit_code == 1 and "no finished trajectory" in r.output


def test_batch_log_lines_carry_rate_and_eta(monkeypatch):
    clock = iter([0.0, 0.0, 10.0, 20.0])  # start, two updates, the run finishing
    monkeypatch.setattr("fcsweep.sweep.progress.time.time", lambda: next(clock))
    buf = io.StringIO()
    p = Progress(3, stream=buf, log_every=0.0)
    p.update("abc", "eta=0.1", 0, 1000)
    p.update("abc", "eta=0.1", 500, 1000)  # 500 steps in 10 s
    p.run_finished("abc", "run 0 abc computed")  # one run in 20 s: two left
    text = buf.getvalue()
    assert "step 500/1000 (50%), 50 steps/s, ETA 10 s" in text
    assert "[1/3] run 0 abc computed; 20 s per run, about 40 s left" in text


def test_cost_model_adds_overheads_and_shares_the_core():
    cost = StepCost(rate=1e5, share=0.5, source="test")
    params = {"N": 100}
    cpu = run_cpu_seconds(params, 1000, 2, cost)
    assert cpu == pytest.approx(1.0 + 0.05 + 2 * 0.02)
    assert run_seconds(params, 1000, 2, cost) == pytest.approx(cpu / 0.5 + 0.07 + 2 * 0.03)
    assert wall_time([2, 3, 4, 3], 2) == 6  # longest first onto the freer process: 4+2 | 3+3
    assert wall_time([5, 1], 4) == 5


def test_compile_command_names_the_cache():
    r = invoke("compile")
    assert r.exit_code == 0 and "cache" in r.output and ".cache" in r.output or "fcsweep-" in r.output


def test_first_use_says_it_compiles_before_any_run(monkeypatch, tmp_path):
    """On a cold cache, simulate announces the compilation (naming the cache), reports
    elapsed time, and does it before the first run starts (so no run is charged)."""
    import time

    from fcsweep.simulation import Simulation
    from fcsweep.sweep.warmup import cache_dir, compile_kernels

    monkeypatch.setattr("fcsweep.sweep.warmup.kernels_cached", lambda: False)  # as on first use
    lines = []
    advance = Simulation.advance
    with monkeypatch.context() as m:  # a compilation takes time (here: loaded kernels, so pretend)
        m.setattr(Simulation, "advance", lambda self, n: (time.sleep(0.1), advance(self, n)))
        compile_kernels(lines.append, tick=0.02)
    assert lines[0].startswith(f"compiling kernels (first use, cached in {cache_dir()})")
    assert any(line.startswith("compiling kernels ... ") for line in lines[1:-1])
    assert lines[-1].startswith("kernels compiled in")
    r = invoke("simulate", SMOKE, "-o", tmp_path / "s", "--log-every", "0")
    assert r.exit_code == 0, r.output
    assert r.output.index("compiling kernels (first use") < r.output.index("[1/4]")
