"""Training survives what batch schedulers and users do to it: SIGTERM saves like Ctrl-C, an early
first checkpoint, SIGKILL (during start-up or training) leaves a directory that resumes or starts
afresh, a second session on the same --out is refused by name, a time-limit stop is recorded, and
a rounded-up --total-timesteps is reported. Each test drives `cepam-gym train` in a subprocess on a
tiny config (a few seconds each)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def tiny(tmp_path):
    import yaml

    from cepam_gym_agents.config.files import load_config

    d = load_config(str(ROOT / "configs" / "quick.yaml")).to_dict()
    d["env"]["num_envs"] = 4
    d["hyperparameters"].update(n_steps=32, batch_size=64, n_epochs=1)
    d["eval"].update(episodes=2, every_steps=10**7)
    d["checkpoint"]["every_steps"] = 10**7
    d["total_timesteps"] = 20_000  # the first checkpoint comes at 10 %: 2000 steps
    d["time_limit_minutes"] = None
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(d))
    return path


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT), env.get("PYTHONPATH", "")])
    return env


def _start(*args) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "cepam_gym.cli", "train", "--quiet", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
        cwd=ROOT,
    )


def _run(*args, timeout=120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cepam_gym.cli", "train", "--quiet", *map(str, args)],
        capture_output=True,
        text=True,
        env=_env(),
        cwd=ROOT,
        timeout=timeout,
    )


def _wait_for(cond, proc, timeout=90.0):
    t = time.time()
    while time.time() - t < timeout:
        if cond():
            return
        if proc.poll() is not None:
            raise AssertionError(f"training ended early ({proc.returncode}): {proc.stderr.read()[-2000:]}")
        time.sleep(0.1)
    raise AssertionError("timed out")


def _status(run: Path) -> dict:
    return json.loads((run / "run.json").read_text())


def _checkpoint(run: Path):
    p = run / "checkpoints" / "latest.json"
    return json.loads(p.read_text()) if p.is_file() else None


def test_sigterm_saves_like_sigint_and_resumes(tiny, tmp_path):
    run = tmp_path / "run"
    p = _start("--config", tiny, "--out", run)
    _wait_for(lambda: _checkpoint(run) is not None, p)  # the early first checkpoint
    first = _checkpoint(run)["steps"]
    assert 2000 <= first < 20_000
    time.sleep(1.0)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM, err
    ck = _checkpoint(run)
    assert ck["interrupted"] and ck["steps"] >= first and (run / ck["model"]).is_file()
    assert _status(run)["status"] == "interrupted" and "SIGTERM" in err
    r = _run("--out", run, "--resume", "--total-timesteps", ck["steps"] + 256)
    assert r.returncode == 0, r.stderr
    session = _status(run)["sessions"][-1]
    assert session["start_step"] == ck["steps"] and session["status"] == "finished"


def test_sigkill_during_training_resumes_from_the_last_checkpoint_and_the_lock_is_not_stale(tiny, tmp_path):
    run = tmp_path / "run"
    p = _start("--config", tiny, "--out", run)
    _wait_for(lambda: _checkpoint(run) is not None, p)
    p.kill()
    p.wait()
    steps = _checkpoint(run)["steps"]
    again = _run("--config", tiny, "--out", run)
    assert again.returncode == 2 and "already holds a run: pass --resume" in again.stderr
    r = _run("--out", run, "--resume", "--total-timesteps", steps + 256)
    assert r.returncode == 0, r.stderr
    sessions = _status(run)["sessions"]
    assert sessions[0]["status"] == "killed" and sessions[-1]["start_step"] == steps


def test_killed_during_start_up_starts_afresh(tiny, tmp_path):
    run = tmp_path / "run"
    p = _start("--config", tiny, "--out", run)
    _wait_for(lambda: (run / "config.yaml").is_file(), p)
    p.kill()  # SIGKILL before any model is saved
    p.wait()
    assert not (run / "checkpoints" / "latest.json").exists()
    r = _run("--config", tiny, "--out", run, "--total-timesteps", 256)
    assert r.returncode == 0 and "starting it afresh" in r.stderr, r.stderr
    # and --resume on such a directory starts afresh too
    run2 = tmp_path / "run2"
    p = _start("--config", tiny, "--out", run2)
    _wait_for(lambda: (run2 / "config.yaml").is_file(), p)
    p.kill()
    p.wait()
    r = _run("--out", run2, "--resume", "--total-timesteps", 256)
    assert r.returncode == 0 and "starting afresh" in r.stderr, r.stderr
    assert _status(run2)["status"] == "finished"


def test_second_session_on_the_same_out_is_refused_by_name(tiny, tmp_path):
    run = tmp_path / "run"
    p = _start("--config", tiny, "--out", run)
    try:
        _wait_for(lambda: (run / ".train.lock").is_file() and (run / ".train.lock").read_text().strip(), p)
        r = _run("--out", run, "--resume")
        assert r.returncode == 2, r.stderr
        assert f"in use by another training session (pid {p.pid}" in r.stderr
        r = _run("--config", tiny, "--out", run)
        assert r.returncode == 2 and f"pid {p.pid}" in r.stderr
    finally:
        p.send_signal(signal.SIGTERM)
        p.communicate(timeout=60)


def test_time_limit_stop_is_loud_and_recorded_and_rounding_reported(tiny, tmp_path):
    import yaml

    d = yaml.safe_load(tiny.read_text())
    d["time_limit_minutes"] = 0.05  # 3 s of training
    d["total_timesteps"] = 10**6
    cfg = tmp_path / "limited.yaml"
    cfg.write_text(yaml.safe_dump(d))
    run = tmp_path / "run"
    r = _run("--config", cfg, "--out", run)
    assert r.returncode == 0, r.stderr
    assert "STOPPED BY THE TIME LIMIT" in r.stderr
    st = _status(run)
    assert st["status"] == "stopped_by_time_limit" and st["sessions"][-1]["end_step"] < 10**6
    # --total-timesteps rounded up by PPO (n_steps 32 x 4 envs = 128): said, not silent
    r = _run("--config", tiny, "--out", tmp_path / "r2", "--total-timesteps", 1000)
    assert r.returncode == 0 and "training 1024 steps, not 1000" in r.stderr, r.stderr
    assert json.loads((tmp_path / "r2" / "summary.json").read_text())["steps"] == 1024
    assert _status(tmp_path / "r2")["sessions"][-1]["planned_steps"] == 1024


def test_lock_without_flock_detects_a_stale_pid(tmp_path, monkeypatch):
    """The fallback lock (no fcntl): a lock file whose pid is gone is taken over; a live one refuses."""
    import builtins

    from cepam_gym_agents.train import RunLock

    real_import = builtins.__import__

    def no_fcntl(name, *a, **k):
        if name == "fcntl":
            raise ImportError("no fcntl here")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_fcntl)
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    (tmp_path / ".train.lock").write_text(f"pid {int(dead.stdout)} since then\n")
    lock = RunLock(tmp_path)
    lock.acquire()  # the stale lock is taken over
    assert f"pid {os.getpid()}" in (tmp_path / ".train.lock").read_text()
    with pytest.raises(FileExistsError, match=f"in use by another training session \\(pid {os.getpid()}"):
        RunLock(tmp_path).acquire()
    lock.release()
    assert not (tmp_path / ".train.lock").exists()


def test_training_runs_inside_a_worker_thread(tiny, tmp_path):
    """Ray Tune runs function trainables in a thread, where no signal handler can be set: the
    trainer then leaves SIGTERM to its host instead of failing."""
    import threading

    from cepam_gym_agents.train import main as train_main

    out, codes = tmp_path / "run", []
    args = ["--config", str(tiny), "--out", str(out), "--total-timesteps", "256", "--quiet"]
    t = threading.Thread(target=lambda: codes.append(train_main(args)))
    t.start()
    t.join(timeout=300)
    assert codes == [0], codes
    assert (out / "model.zip").is_file()
