"""workflows/: the SLURM array script (with a fake sbatch, and a SIGTERM as at a time limit),
the cron example (run as cron would, with flock) and the dask-jobqueue launcher run as a
script, as users run it (job script and a local run)."""

from __future__ import annotations

import fcntl
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from fcsweep.config import load_config
from fcsweep.io.status import read_status

ROOT = Path(__file__).resolve().parents[1]
WF = ROOT / "workflows"

CONFIG = """
output: {out}
seed: 4
grid:
  v0: [0.03, 0.06]
model: {{N: 16, eta: 0.1}}
run: {{steps: 100, sample_every: 20, checkpoint_every: 40}}
"""

FAKE_SBATCH = r"""#!/bin/bash
# fake sbatch: runs every task of --array=A-B at once on this machine, then waits
array=""; args=()
for a in "$@"; do
  case "$a" in --array=*) array="${a#--array=}";; *) args+=("$a");; esac
done
echo "sbatch $*" >> "$FAKE_SBATCH_LOG"
lo=${array%-*}; hi=${array#*-}; hi=${hi%\%*}
pids=()
for i in $(seq "$lo" "$hi"); do
  SLURM_ARRAY_TASK_ID=$i SLURM_ARRAY_JOB_ID=42 bash "${args[@]}" > "$FAKE_SBATCH_DIR/task-$i.log" 2>&1 &
  pids+=($!)
done
rc=0; for p in "${pids[@]}"; do wait "$p" || rc=$?; done
echo "Submitted batch job 42"
exit $rc
"""


@pytest.fixture()
def env(tmp_path):
    """PATH with a `fcsweep` shim (this interpreter) and a fake `sbatch`."""
    from fcsweep.simulation import Simulation

    Simulation.from_lattice(16, eta=0.1, v0=0.03, seed=0).advance(1)  # fill numba's cache first
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "fcsweep"
    shim.write_text(f'#!/bin/bash\nexec {shlex.quote(sys.executable)} -m fcsweep.cli "$@"\n')
    sb = bin_dir / "sbatch"
    sb.write_text(FAKE_SBATCH)
    for f in (shim, sb):
        f.chmod(0o755)
    e = dict(os.environ)
    e["PATH"] = f"{bin_dir}:{e.get('PATH', '')}"
    e["FAKE_SBATCH_LOG"] = str(tmp_path / "sbatch.log")
    e["FAKE_SBATCH_DIR"] = str(tmp_path)
    e.pop("SLURM_ARRAY_TASK_ID", None)
    return e


def _config(tmp_path) -> Path:
    path = tmp_path / "sweep.yaml"
    path.write_text(CONFIG.format(out=tmp_path / "out"))
    return path


def test_slurm_array_script_with_task_id_and_fake_sbatch(tmp_path, env):
    cfg_path = _config(tmp_path)
    cfg = load_config(cfg_path)
    ids = [s.run_id for s in cfg.runs()]
    script = WF / "slurm_array.sh"
    # without an array task id the script refuses to run
    r = subprocess.run(["bash", str(script), str(cfg_path)], env=env, capture_output=True, text=True)
    assert r.returncode == 2 and "SLURM_ARRAY_TASK_ID" in r.stderr
    # one array task, as SLURM would start it: only run 1
    r = subprocess.run(["bash", str(script), str(cfg_path)], env={**env, "SLURM_ARRAY_TASK_ID": "1"},
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert read_status(cfg.run_dir(ids[1]))["status"] == "done" and read_status(cfg.run_dir(ids[0])) is None
    # the README's submission line, verbatim, against the fake sbatch: the whole array
    line = f"sbatch --array=0-$(($(fcsweep list-runs {cfg_path} --count)-1)) {script} {cfg_path}"
    r = subprocess.run(["bash", "-c", line], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr + "".join(p.read_text() for p in tmp_path.glob("task-*.log"))
    assert "--array=0-1 " in (tmp_path / "sbatch.log").read_text()
    assert all(read_status(cfg.run_dir(i))["status"] == "done" for i in ids)
    assert "skipped (already done)" in (tmp_path / "task-1.log").read_text()
    assert "computed" in (tmp_path / "task-0.log").read_text()


def test_cron_example_line_runs_and_respects_flock(tmp_path, env):
    line = next(l for l in (WF / "crontab.example").read_text().splitlines() if l and not l.startswith("#"))
    command = line.split(None, 5)[5]  # drop the five time fields
    sweeps = tmp_path / "sweeps"
    (sweeps / "configs").mkdir(parents=True)
    (sweeps / "workflows").symlink_to(WF)
    (sweeps / "configs" / "phase.yaml").write_text(CONFIG.format(out="runs/phase"))
    command = command.replace("/home/me/sweeps", str(sweeps)).replace("/home/me/venv/bin/fcsweep", "fcsweep")
    r = subprocess.run(["bash", "-c", command], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    log = (sweeps / "phase.cron.log").read_text()
    assert "cron tick" in log and "2 computed" in log
    cfg = load_config(sweeps / "configs" / "phase.yaml").with_output(sweeps / "runs" / "phase")
    assert all(read_status(cfg.run_dir(s.run_id))["status"] == "done" for s in cfg.runs())
    # while the previous tick holds the flock, a new tick exits 0 at once and does nothing
    with open(sweeps / "configs" / "phase.yaml.cron.lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        r = subprocess.run(["bash", "-c", command], env=env, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0
    log2 = (sweeps / "phase.cron.log").read_text()[len(log):]
    assert "cron tick skipped" in log2 and "run(s) of" not in log2


def _launch(*args, env=None, timeout=300):
    """The launcher as users run it: ``python workflows/jobqueue_launch.py ...`` (the
    script's directory first on sys.path, so a file shadowing dask_jobqueue would bite)."""
    return subprocess.run([sys.executable, str(WF / "jobqueue_launch.py"), *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, env=env)


def test_no_workflow_file_shadows_a_package():
    assert not (WF / "dask_jobqueue.py").exists()
    assert not [p for p in WF.glob("*.py") if p.stem in ("dask", "distributed", "dask_jobqueue", "fcsweep")]


def test_jobqueue_launcher_renders_slurm_job_script(tmp_path):
    pytest.importorskip("dask_jobqueue")
    r = _launch(_config(tmp_path), "--system", "slurm", "--dry-run", "--queue", "short", "--account", "proj1",
                "--walltime", "02:00:00", "--memory", "3GB", "--interface", "lo")
    assert r.returncode == 0, r.stderr
    script = r.stdout
    for needle in ("#SBATCH -J fcsweep", "#SBATCH -p short", "#SBATCH -A proj1", "#SBATCH -t 02:00:00",
                   "NUMBA_NUM_THREADS=1", "distributed.cli.dask_worker", "--interface lo"):
        assert needle in script, needle
    assert "has no attribute" not in r.stderr
    assert not (tmp_path / "out").exists()


def test_jobqueue_launcher_local_run(tmp_path):
    cfg_path = _config(tmp_path)
    r = _launch(cfg_path, "--local", "--jobs", "1")
    assert r.returncode == 0, r.stderr
    cfg = load_config(cfg_path)
    assert all(read_status(cfg.run_dir(s.run_id))["status"] == "done" for s in cfg.runs())


def test_slurm_script_declares_requeue_append_and_signal():
    text = (WF / "slurm_array.sh").read_text()
    for directive in ("#SBATCH --requeue", "#SBATCH --open-mode=append", "#SBATCH --signal=B:TERM@60"):
        assert directive in text, directive


def test_slurm_script_logs_and_forwards_sigterm(tmp_path, env):
    """SIGTERM to the batch shell (what --signal=B:TERM sends): a log line, fcsweep
    checkpoints, exit 143, and the next attempt resumes."""
    import signal
    import time

    cfg_path = _config(tmp_path)
    cfg = load_config(cfg_path)
    spec = cfg.runs()[0]
    e = {**env, "SLURM_ARRAY_TASK_ID": "0", "FCSWEEP_TEST_SLOW": "0.3"}
    p = subprocess.Popen(["bash", str(WF / "slurm_array.sh"), str(cfg_path)], env=e, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    t0 = time.time()
    while (read_status(cfg.run_dir(spec.run_id)) or {}).get("status") != "running" and time.time() - t0 < 120:
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    out, _ = p.communicate(timeout=60)
    assert p.returncode == 143, out
    assert "received SIGTERM" in out and "exited with status 143" in out
    st = read_status(cfg.run_dir(spec.run_id))
    assert st["status"] == "interrupted" and st["signal"] == "SIGTERM"
    r = subprocess.run(["bash", str(WF / "slurm_array.sh"), str(cfg_path)], env={**env, "SLURM_ARRAY_TASK_ID": "0"},
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and read_status(cfg.run_dir(spec.run_id))["status"] == "done"
