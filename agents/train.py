"""``cepam-gym train``: train SAC, PPO or TD3 on a CE-PAM env from a YAML config.

    cepam-gym train --config configs/quick.yaml [--total-timesteps N] [--seed S] [--out DIR] [--resume]

The run directory (default ``runs/<config name>-s<seed>``) receives:

| file | what |
|---|---|
| ``config.yaml`` | the resolved config (overrides applied; ``--config DIR/config.yaml`` reruns it) |
| ``run.json`` | seed, command line, package versions, git commit, and one entry per training session |
| ``model.zip``, ``vecnormalize.pkl`` | the model at the end of training (and its observation statistics) |
| ``best_model.zip``, ``best_vecnormalize.pkl`` | the model with the best periodic evaluation score |
| ``checkpoints/`` | periodic checkpoints; ``latest.json`` names the newest (``--resume`` starts there) |
| ``evaluations.json`` | every periodic evaluation (benchmark metrics) |
| ``tb/``, ``logs/`` | TensorBoard events and CSV: losses, returns, reward terms, errors, evaluations |

Ctrl-C (SIGINT) or SIGTERM (what batch schedulers send) saves a checkpoint of the current model
(and the replay buffer) before exiting with 130 or 143; ``--resume`` continues from the newest
checkpoint with the step count it had. The first checkpoint comes early (after 10 % of the session's
steps or 2 minutes, whichever first), then every ``checkpoint.every_steps``. After a SIGKILL or a
crash, ``--resume`` continues from the newest loadable model (checkpoint, final or best); a
directory that never saved a model (killed during start-up) starts afresh, with or without
``--resume``. A run directory is locked while a session trains in it (``.train.lock``, an OS lock
released when the process dies, so a lock left by a killed run never blocks): a second session on
it is refused, naming the first one's pid. A stop by ``time_limit_minutes`` is reported loudly and
recorded in ``run.json`` (status ``stopped_by_time_limit``, not ``finished``); a
``--total-timesteps`` that the algorithm rounds up (PPO collects ``n_steps x num_envs`` at a time)
is reported with the number it will train.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from cepam_gym._cli_errors import debug_on, guarded_load, report, user_error_types

from .config import ConfigError, TrainConfig, algorithm_class, dump_config, load_config

EXIT_INTERRUPTED = 130  # 128 + SIGINT; a SIGTERM exits with 128 + 15
FIRST_CHECKPOINT_FRACTION = 0.1  # of the session's steps
FIRST_CHECKPOINT_MINUTES = 2.0
LOCK_NAME = ".train.lock"


# --------------------------------------------------------------------------- locking and signals
class RunLock:
    """An exclusive OS lock on ``run/.train.lock`` (``fcntl.flock``: released by the kernel when
    the holder dies, SIGKILL included, so a stale file never blocks). The file records the
    holder's pid and start time for the refusal message."""

    def __init__(self, run: Path):
        self.path = Path(run) / LOCK_NAME
        self.fh = None

    def acquire(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            import fcntl
        except ImportError:  # not POSIX: an exclusive-create lock file, stale if its pid is gone
            return self._acquire_exclusive_create()
        fh = open(self.path, "a+")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = fh.read().strip() or "unknown pid"
            fh.close()
            raise self._refusal(holder) from None
        fh.seek(0)
        stale = fh.read().strip()
        if stale:
            self._say_stale(stale)
        fh.seek(0)
        fh.truncate()
        fh.write(self._holder())
        fh.flush()
        self.fh = fh

    def _acquire_exclusive_create(self) -> None:
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                holder = self.path.read_text().strip()
                pid = holder.split()[1] if holder.startswith("pid ") else ""
                if pid.isdigit() and not _pid_alive(int(pid)):
                    self._say_stale(holder)
                    self.path.unlink(missing_ok=True)
                    continue
                raise self._refusal(holder or "unknown pid") from None
            with os.fdopen(fd, "w") as fh:
                fh.write(self._holder())
            self.fh = False  # marks "held, by file"
            return
        raise self._refusal("a session that keeps re-creating the lock")

    def _holder(self) -> str:
        return f"pid {os.getpid()} since {_now()}\n"

    def _refusal(self, holder: str) -> FileExistsError:
        return FileExistsError(
            f"run directory {self.path.parent} is in use by another training session "
            f"({holder}); wait for it to end, or pass another --out"
        )

    def _say_stale(self, holder: str) -> None:
        pid = holder.split()[1] if holder.startswith("pid ") else "?"
        if not pid.isdigit() or not _pid_alive(int(pid)):
            print(
                f"cepam-gym train: {self.path.parent}: lock of pid {pid} is stale (process gone): "
                "taking over",
                file=sys.stderr,
            )

    def release(self) -> None:
        if self.fh is False:
            self.path.unlink(missing_ok=True)
        elif self.fh is not None:
            self.fh.seek(0)
            self.fh.truncate()
            self.fh.close()  # closing drops the flock
        self.fh = None


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class _StopSignal(KeyboardInterrupt):
    """SIGTERM turned into the KeyboardInterrupt path (save, then exit 128 + signum)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _on_sigterm(signum, frame):
    raise _StopSignal(signum)


# --------------------------------------------------------------------------- run directory
def package_versions() -> dict:
    from importlib import metadata

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name in ("cepam-gym", "stable-baselines3", "torch", "numpy", "gymnasium", "numba", "scipy", "pyyaml"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def git_state() -> dict:
    root = Path(__file__).resolve().parent.parent
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10
        ).stdout.strip()
        dirty = (
            subprocess.run(
                ["git", "status", "--porcelain", "--untracked-files=no"],
                cwd=root,
                capture_output=True,
                text=True,
                timeout=10,
            ).stdout.strip()
            != ""
        )
        return {"commit": commit or None, "dirty": dirty if commit else None}
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}


def _write_json(path: Path, data) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=str))
    os.replace(tmp, path)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


# --------------------------------------------------------------------------- building blocks
def make_train_env(cfg: TrainConfig, seed: int):
    """SB3 VecEnv: native batched env (one process) -> agent features -> VecNormalize (optional)."""
    from cepam_gym.integrations.sb3 import make_sb3_vec_env

    from .features import make_agent_vec_env

    env = make_sb3_vec_env(cfg.env.id, num_envs=cfg.env.num_envs, seed=seed, **cfg.env.kwargs)
    return make_agent_vec_env(env, cfg.agent)


def _normalize(env, cfg: TrainConfig, load_from: Path | None = None):
    from stable_baselines3.common.vec_env import VecNormalize

    if not cfg.normalize.enabled:
        return env
    if load_from is not None:
        vn = VecNormalize.load(str(load_from), env)
        vn.training = True
        return vn
    gamma = cfg.hyperparameters.get("gamma", 0.99)
    return VecNormalize(
        env,
        norm_obs=cfg.normalize.obs,
        norm_reward=cfg.normalize.reward,
        clip_obs=cfg.normalize.clip_obs,
        clip_reward=cfg.normalize.clip_reward,
        gamma=gamma,
    )


def _hyperparameters(cfg: TrainConfig) -> dict:
    hp = dict(cfg.hyperparameters)
    noise = hp.pop("action_noise", None)
    if noise is not None:
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        cls = NormalActionNoise if noise["type"] == "normal" else OrnsteinUhlenbeckActionNoise
        hp["action_noise"] = cls(np.zeros(2), np.full(2, noise["sigma"]))
    if isinstance(hp.get("train_freq"), list):
        hp["train_freq"] = tuple(hp["train_freq"])
    return hp


def _policy_kwargs(cfg: TrainConfig) -> dict:
    pk = dict(cfg.policy_kwargs)
    if "activation_fn" in pk:
        import torch.nn

        from .config import ACTIVATIONS

        pk["activation_fn"] = getattr(torch.nn, ACTIVATIONS[pk["activation_fn"]])
    return pk


def _policy(cfg: TrainConfig, env) -> tuple:
    """(policy, policy_kwargs) for the algorithm's constructor: the asymmetric actor-critic when
    the critic is privileged (it is told how many input columns the actor may see)."""
    from .config import policy_name

    pk = _policy_kwargs(cfg)
    if not cfg.agent.privileged_critic:
        return policy_name(cfg.algorithm), pk
    from .asymmetric import AsymmetricActorCriticPolicy

    return AsymmetricActorCriticPolicy, {**pk, "actor_dim": env.features.actor_dim}


def _eval_env_spec(cfg: TrainConfig) -> tuple[str, dict, object]:
    """(env id, kwargs, trace spec) of the periodic evaluation: the eval suite's, else the
    training env scored as the benchmark scores its version (v1 ids: the settling allowance)."""
    from cepam_gym.bench.suites import SUITES, trace_spec_for

    if cfg.eval.suite is None:
        return cfg.env.id, dict(cfg.env.kwargs), trace_spec_for(cfg.env.id)
    s = SUITES[cfg.eval.suite]
    return s.env_id, dict(s.env_kwargs), s.traces


# --------------------------------------------------------------------------- the callback
def _make_callback_class():
    from stable_baselines3.common.callbacks import BaseCallback

    class RunCallback(BaseCallback):
        """Logs the env's reward terms and errors, evaluates, keeps the best model, checkpoints,
        and draws the progress bar (with the latest evaluation score)."""

        def __init__(self, trainer: Trainer):
            super().__init__(verbose=0)
            self.t = trainer
            self._sums: dict[str, float] = {}
            self._count = 0

        def _on_training_start(self) -> None:
            n = self.num_timesteps
            cfg = self.t.cfg
            self.next_log = (n // cfg.log_every_steps + 1) * cfg.log_every_steps
            self.next_eval = (n // cfg.eval.every_steps + 1) * cfg.eval.every_steps
            self.next_ckpt = (n // cfg.checkpoint.every_steps + 1) * cfg.checkpoint.every_steps
            # an early first checkpoint: a run killed early still has something to resume from
            remaining = max(1, cfg.total_timesteps - n)
            self.first_ckpt = n + max(1, int(FIRST_CHECKPOINT_FRACTION * remaining))
            self.first_ckpt_wall = time.perf_counter() + 60.0 * FIRST_CHECKPOINT_MINUTES
            self.t.open_progress(n)

        def _on_step(self) -> bool:
            self._accumulate(self.locals.get("infos") or [])
            n = self.num_timesteps
            if n >= self.next_log:
                self._log()
                self.next_log += self.t.cfg.log_every_steps * max(
                    1, (n - self.next_log) // self.t.cfg.log_every_steps + 1
                )
            if n >= self.next_eval:
                self.t.evaluate(n)
                self.next_eval += self.t.cfg.eval.every_steps * max(
                    1, (n - self.next_eval) // self.t.cfg.eval.every_steps + 1
                )
            if self.first_ckpt is not None and (
                n >= self.first_ckpt or time.perf_counter() >= self.first_ckpt_wall
            ):
                self.first_ckpt = None
                if n < self.next_ckpt:
                    self.t.save_checkpoint(n)
            if n >= self.next_ckpt:
                self.first_ckpt = None
                self.t.save_checkpoint(n)
                self.next_ckpt += self.t.cfg.checkpoint.every_steps * max(
                    1, (n - self.next_ckpt) // self.t.cfg.checkpoint.every_steps + 1
                )
            self.t.progress_to(n)
            limit = self.t.cfg.time_limit_minutes
            if limit is not None and self.t.wall() >= 60.0 * limit:
                self.t.stopped_by_time = True
                return False
            return True

        def _accumulate(self, infos) -> None:
            if not infos or "length" not in infos[0]:
                return
            keys = self.t.info_keys
            vals = np.array([[inf[k] for k in keys] for inf in infos], dtype=float)
            L, Lt = vals[:, keys.index("length")], vals[:, keys.index("target_length")]
            row = {k: vals[:, j].sum() for j, k in enumerate(keys) if k.startswith("reward_")}
            row["length_error_mm"] = 1000.0 * np.abs(L - Lt).sum()
            if self.t.track_stiffness:
                K, Kt = vals[:, keys.index("stiffness")], vals[:, keys.index("target_stiffness")]
                row["stiffness_error_pct"] = 100.0 * np.abs((K - Kt) / Kt).sum()
            for k, v in row.items():
                self._sums[k] = self._sums.get(k, 0.0) + float(v)
            self._count += len(infos)

        def _log(self) -> None:
            if self._count:
                for k, v in self._sums.items():
                    self.logger.record(f"env/{k}", v / self._count)
            self.logger.record("time/wall_s", time.perf_counter() - self.t.t0 + self.t.wall_before)
            self.logger.dump(self.num_timesteps)
            self._sums, self._count = {}, 0

    return RunCallback


class Trainer:
    """One training session of one run directory (new or resumed)."""

    def __init__(
        self,
        cfg: TrainConfig,
        run_dir: Path,
        resume: bool = False,
        quiet: bool = False,
        argv: list[str] | None = None,
    ):
        self.cfg, self.run, self.resume, self.quiet = cfg, Path(run_dir), resume, quiet
        self.argv = argv
        self.ckpt_dir = self.run / "checkpoints"
        self.best_score = float("inf")
        self.last_score: float | None = None
        self.evaluations: list[dict] = []
        self.bar = None
        self.stopped_by_time = False
        self.wall_before = 0.0
        self.t0 = time.perf_counter()

    # ----------------------------------------------------------------- set-up
    def setup(self) -> None:
        import torch
        from stable_baselines3.common.logger import Logger, make_output_format
        from stable_baselines3.common.utils import set_random_seed

        cfg = self.cfg
        torch.set_num_threads(cfg.torch_threads)
        self.run.mkdir(parents=True, exist_ok=True)
        self.ckpt_dir.mkdir(exist_ok=True)
        algo = algorithm_class(cfg.algorithm)
        candidates = self._resume_candidates() if self.resume else []
        if self.resume and not candidates:
            self._say(
                f"{self.run}: no saved model to resume (killed during start-up?): starting afresh", err=True
            )
            self.resume = False
        latest = candidates[0] if candidates else None
        start = int(latest["steps"]) if latest else 0
        # a resumed session draws new episodes: seed + steps done
        seed = cfg.seed + start
        try:
            env = make_train_env(cfg, seed)
        except (ValueError, TypeError) as e:
            raise ConfigError(f"env {cfg.env.id} (env.kwargs of the config): {e}") from e
        raw = env
        if latest:
            env, self.model, latest = self._load_newest(candidates, raw, algo)
        else:
            env = _normalize(env, cfg)
        if latest:
            if latest.get("replay_buffer") and hasattr(self.model, "load_replay_buffer"):
                buf = self.run / latest["replay_buffer"]
                guarded_load(buf, "replay buffer", self.model.load_replay_buffer, str(buf))
            set_random_seed(seed)
            evals = self.run / "evaluations.json"
            if evals.is_file():
                self.evaluations = guarded_load(
                    evals, "evaluation log", lambda: json.loads(evals.read_text())
                )
                scores = [e["score"] for e in self.evaluations if e.get("score") is not None]
                self.best_score = min(scores, default=float("inf"))
                self.last_score = scores[-1] if scores else None
            self.wall_before = float(latest.get("wall_s", 0.0))
        else:
            try:
                policy, pk = _policy(cfg, raw)
                self.model = algo(
                    policy,
                    env,
                    seed=cfg.seed,
                    verbose=0,
                    device="cpu",
                    policy_kwargs=pk,
                    **_hyperparameters(cfg),
                )
            except (AssertionError, ValueError, TypeError) as e:  # SB3 checks its arguments with asserts
                raise ConfigError(
                    f"{cfg.algorithm} rejected the hyperparameters {cfg.hyperparameters} "
                    f"or policy_kwargs {cfg.policy_kwargs}: {e}"
                ) from e
        self.env = env
        self.vecnorm = env if cfg.normalize.enabled else None
        self.start_step = int(self.model.num_timesteps)
        (self.run / "logs").mkdir(exist_ok=True)
        self.model.set_logger(
            Logger(
                str(self.run),
                [
                    make_output_format("tensorboard", str(self.run / "tb")),
                    make_output_format("csv", str(self.run / "logs"), log_suffix=f"_{self.start_step}"),
                ],
            )
        )
        core = raw.unwrapped.venv.core  # SB3 adapter -> CEPAMVectorEnv -> batch
        self.track_stiffness = bool(core.task.track_stiffness)
        self.info_keys = ["length", "target_length", "stiffness", "target_stiffness"] + [
            f"reward_{t}" for t in _reward_terms()
        ]
        self.eval_id, self.eval_kwargs, self.eval_traces = _eval_env_spec(cfg)
        self._write_run_json(status="running")

    def _latest(self) -> dict | None:
        """The newest resumable model of the run: the checkpoint index, else the final model, else
        the best one (a run killed before its first checkpoint). ``None`` if it saved none."""
        for cand in self._resume_candidates():
            return cand
        return None

    def _load_newest(self, candidates: list[dict], raw_env, algo):
        """Load the newest candidate that loads; a corrupted one is reported and skipped."""
        errors = []
        for cand in candidates:
            norm = self.run / cand["vecnormalize"] if cand.get("vecnormalize") else None
            model_path = self.run / cand["model"]
            try:
                env = guarded_load(norm, "observation normalizer", _normalize, raw_env, self.cfg, norm)
                model = guarded_load(
                    model_path,
                    f"{self.cfg.algorithm} model",
                    algo.load,
                    str(model_path),
                    env=env,
                    device="cpu",
                )
            except (ValueError, FileNotFoundError) as e:
                errors.append(e)
                self._say(f"cepam-gym train: {e}; trying an older model", err=True)
                continue
            if cand is not candidates[0]:
                self._say(f"resuming from {cand['model']} (step {cand['steps']})", err=True)
            return env, model, cand
        raise errors[0]

    def _resume_candidates(self) -> list[dict]:
        """Resumable models, newest first (each a checkpoint-index dict with a ``source``)."""
        out = []
        path = self.ckpt_dir / "latest.json"
        if path.is_file():
            meta = guarded_load(path, "checkpoint index", lambda: json.loads(path.read_text()))
            out.append({**meta, "source": "checkpoint"})
        for model, norm, info, key in (
            ("model.zip", "vecnormalize.pkl", "summary.json", "steps"),
            ("best_model.zip", "best_vecnormalize.pkl", "best.json", "step"),
        ):
            if (self.run / model).is_file() and (self.run / info).is_file():
                try:
                    steps = int(json.loads((self.run / info).read_text())[key])
                except (ValueError, KeyError, TypeError):
                    continue
                out.append(
                    {
                        "steps": steps,
                        "model": model,
                        "replay_buffer": None,
                        "source": model,
                        "vecnormalize": norm if (self.run / norm).is_file() else None,
                    }
                )
        return sorted(out, key=lambda m: -int(m["steps"]))

    def _write_run_json(self, status: str, **extra) -> None:
        path = self.run / "run.json"
        data = (
            json.loads(path.read_text())
            if path.is_file()
            else {
                "seed": self.cfg.seed,
                "created": _now(),
                "versions": package_versions(),
                "git": git_state(),
                "sessions": [],
            }
        )
        self._session_extra = {**getattr(self, "_session_extra", {}), **extra}
        session = {
            "started": getattr(self, "_started", None) or _now(),
            "argv": self.argv,
            "start_step": self.start_step,
            "status": status,
            "versions": package_versions(),
            **self._session_extra,
        }
        self._started = session["started"]
        if data["sessions"] and data["sessions"][-1].get("started") == session["started"]:
            data["sessions"][-1] = session
        else:
            last = data["sessions"][-1] if data["sessions"] else None
            if last is not None and last.get("status") == "running":
                last["status"] = "killed"  # we hold the run's lock: that session is gone (SIGKILL, crash)
            data["sessions"].append(session)
        data["status"] = status
        _write_json(path, data)

    # ----------------------------------------------------------------- progress
    def open_progress(self, n: int) -> None:
        if self.quiet or self.bar is not None:
            return
        from tqdm import tqdm

        tty = sys.stderr.isatty()
        self.bar = tqdm(
            total=self.cfg.total_timesteps,
            initial=n,
            unit="step",
            unit_scale=True,
            dynamic_ncols=True,
            mininterval=0.5 if tty else 30.0,
            file=sys.stderr,
            desc=f"{self.cfg.algorithm} {self.run.name}",
        )
        self._bar_n = n
        self._postfix()

    def progress_to(self, n: int) -> None:
        if self.bar is not None and n > self._bar_n:
            self.bar.update(n - self._bar_n)
            self._bar_n = n

    def _postfix(self) -> None:
        if self.bar is None:
            return
        if self.last_score is None:
            self.bar.set_postfix_str("eval score: -")
        else:
            self.bar.set_postfix_str(
                f"eval score {self.last_score:.3f} (best {self.best_score:.3f}, lower is better)"
            )

    # ----------------------------------------------------------------- evaluation and saving
    def evaluate(self, n: int) -> dict:
        from .features import Features
        from .policy import AgentPolicy, evaluate

        cfg = self.cfg
        normalizer = self.vecnorm if (self.vecnorm is not None and cfg.normalize.obs) else None

        def make(venv):
            return AgentPolicy(self.model, Features(venv, cfg.agent, venv.unwrapped.core.obs_dim), normalizer)

        t = time.perf_counter()
        m = evaluate(make, self.eval_id, self.eval_kwargs, cfg.eval.episodes, cfg.eval.seed, self.eval_traces)
        m = {
            "step": int(n),
            "wall_s": round(self.wall(), 2),
            "eval_s": round(time.perf_counter() - t, 2),
            **m,
        }
        self.evaluations.append(m)
        _write_json(self.run / "evaluations.json", self.evaluations)
        for k in (
            "score",
            "length_rmse_mm",
            "stiffness_rmse_pct",
            "mean_return",
            "failure_rate",
            "settling_time_s",
        ):
            if m.get(k) is not None:
                self.model.logger.record(f"eval/{k}", m[k])
        self.last_score = m["score"]
        if m["score"] < self.best_score:
            self.best_score = m["score"]
            self.model.save(str(self.run / "best_model.zip"))
            if self.vecnorm is not None:
                self.vecnorm.save(str(self.run / "best_vecnormalize.pkl"))
            _write_json(self.run / "best.json", {"step": int(n), **m})
        self.model.logger.record("eval/best_score", self.best_score)
        self._postfix()
        return m

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.t0

    def save_checkpoint(self, n: int, interrupted: bool = False) -> Path:
        model_rel = f"checkpoints/model_{n}.zip"
        self.model.save(str(self.run / model_rel))
        meta = {
            "steps": int(n),
            "model": model_rel,
            "vecnormalize": None,
            "replay_buffer": None,
            "wall_s": round(self.wall(), 2),
            "interrupted": interrupted,
            "saved": _now(),
        }
        if self.vecnorm is not None:
            meta["vecnormalize"] = f"checkpoints/vecnormalize_{n}.pkl"
            self.vecnorm.save(str(self.run / meta["vecnormalize"]))
        if self.cfg.checkpoint.replay_buffer and hasattr(self.model, "save_replay_buffer"):
            meta["replay_buffer"] = "checkpoints/replay_buffer.pkl"
            self.model.save_replay_buffer(str(self.run / meta["replay_buffer"]))
        _write_json(self.ckpt_dir / "latest.json", meta)
        self._prune()
        return self.run / model_rel

    def _prune(self) -> None:
        steps = sorted(int(p.stem.split("_")[1]) for p in self.ckpt_dir.glob("model_*.zip"))
        for s in steps[: -self.cfg.checkpoint.keep]:
            for p in (self.ckpt_dir / f"model_{s}.zip", self.ckpt_dir / f"vecnormalize_{s}.pkl"):
                p.unlink(missing_ok=True)

    # ----------------------------------------------------------------- the session
    def learn(self, callbacks=()) -> int:
        from stable_baselines3.common.callbacks import CallbackList

        cfg = self.cfg
        remaining = cfg.total_timesteps - self.start_step
        self.t0 = time.perf_counter()
        if remaining <= 0:
            self._say(
                f"{self.run}: already at {self.start_step} >= total_timesteps {cfg.total_timesteps} steps; "
                "pass a larger --total-timesteps to train further"
            )
            return 0
        cb = CallbackList([_make_callback_class()(self), *callbacks])
        chunk = steps_per_collection(self.model)
        planned = -(-remaining // chunk) * chunk
        if planned != remaining:
            self._say(
                f"note: {cfg.algorithm} collects {chunk} steps at a time ({_chunk_why(self.model)}): "
                f"training {planned} steps, not {remaining} (total {self.start_step + planned})",
                err=True,
            )
        self._write_run_json("running", requested_steps=remaining, planned_steps=planned)
        self._say(
            f"training {cfg.algorithm} on {cfg.env.id} x{cfg.env.num_envs} for {planned} steps "
            f"(from step {self.start_step}) -> {self.run}"
        )
        import signal
        import threading

        # signal handlers can only be set from the main thread; a trainer run inside a worker
        # thread (Ray Tune's function trainables) leaves SIGTERM to its host
        main_thread = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGTERM, _on_sigterm) if main_thread else None
        try:
            self.model.learn(
                remaining,
                callback=cb,
                reset_num_timesteps=not self.resume or self.start_step == 0,
                progress_bar=False,
            )
        except KeyboardInterrupt as e:
            if main_thread:
                signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second SIGTERM must not cut the save
            n = int(self.model.num_timesteps)
            self._close_bar()
            path = self.save_checkpoint(n, interrupted=True)
            how = "SIGTERM" if isinstance(e, _StopSignal) else "interrupted (SIGINT)"
            self._write_run_json(
                "interrupted", end_step=n, wall_s=round(self.wall(), 2), ended=_now(), signal=how
            )
            self._say(
                f"{how} at step {n}: saved {path}; continue with cepam-gym train --out {self.run} --resume",
                err=True,
            )
            return 128 + e.signum if isinstance(e, _StopSignal) else EXIT_INTERRUPTED
        finally:
            if main_thread:
                signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)
        n = int(self.model.num_timesteps)
        self.evaluate(n)
        self.model.logger.dump(n)
        self._close_bar()
        self.model.save(str(self.run / "model.zip"))
        if self.vecnorm is not None:
            self.vecnorm.save(str(self.run / "vecnormalize.pkl"))
        self.save_checkpoint(n)
        summary = {
            "steps": n,
            "wall_s": round(self.wall(), 2),
            "stopped_by_time_limit": self.stopped_by_time,
            "best_score": self.best_score,
            "final_score": self.last_score,
            "best": json.loads((self.run / "best.json").read_text()),
        }
        _write_json(self.run / "summary.json", summary)
        status = "stopped_by_time_limit" if self.stopped_by_time else "finished"
        self._write_run_json(
            status,
            end_step=n,
            wall_s=round(self.wall(), 2),
            ended=_now(),
            total_timesteps=cfg.total_timesteps,
        )
        if self.stopped_by_time:
            self._say(
                f"STOPPED BY THE TIME LIMIT: {cfg.time_limit_minutes} min reached at step {n} of "
                f"{cfg.total_timesteps} ({100.0 * n / cfg.total_timesteps:.0f} %); the models are saved; "
                f"continue with cepam-gym train --out {self.run} --resume",
                err=True,
            )
        self._say(
            f"done: {n} steps in {self.wall():.0f} s; final eval score {self.last_score:.3f}, best "
            f"{self.best_score:.3f} (step {summary['best']['step']}); models in {self.run}"
        )
        return 0

    def _close_bar(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def _say(self, msg: str, err: bool = False) -> None:
        if err:  # warnings and stops: shown even with --quiet
            print(msg, file=sys.stderr, flush=True)
        elif not self.quiet:
            print(msg, flush=True)

    def close(self) -> None:
        self._close_bar()
        self.env.close()


def steps_per_collection(model) -> int:
    """Steps the algorithm's ``learn`` advances by at a time: ``n_steps x n_envs`` for on-policy
    algorithms (PPO, A2C), ``train_freq x n_envs`` (steps) or ``n_envs`` for off-policy ones."""
    n_envs = int(getattr(model, "n_envs", 1) or 1)
    n_steps = getattr(model, "n_steps", None)
    if isinstance(n_steps, int) and hasattr(model, "rollout_buffer"):
        return n_steps * n_envs
    tf = getattr(model, "train_freq", None)
    if tf is not None and getattr(getattr(tf, "unit", None), "value", "") == "step":
        return int(tf.frequency) * n_envs
    return n_envs


def _chunk_why(model) -> str:
    n_envs = int(getattr(model, "n_envs", 1) or 1)
    if hasattr(model, "rollout_buffer"):
        return f"n_steps {model.n_steps} x {n_envs} envs"
    return f"{n_envs} envs per step"


def _reward_terms():
    from cepam_gym.tasks.kernel import REWARD_TERMS

    return REWARD_TERMS


def train(
    cfg: TrainConfig,
    run_dir: str | Path,
    resume: bool = False,
    callbacks=(),
    quiet: bool = False,
    argv: list[str] | None = None,
) -> int:
    """Train (or resume) one run; returns the exit code (0, or 130 after Ctrl-C)."""
    run = Path(run_dir)
    lock = RunLock(run)
    lock.acquire()  # before anything is written: a concurrent session is refused by name
    try:
        if not resume:
            if (run / "config.yaml").exists():
                probe = Trainer(cfg, run, quiet=True)
                if probe._resume_candidates():
                    raise FileExistsError(
                        f"run directory {run} already holds a run: pass --resume to continue "
                        "it or --out for a new directory"
                    )
                print(
                    f"cepam-gym train: {run} holds a run that saved no model (killed during start-up?): "
                    "starting it afresh",
                    file=sys.stderr,
                )
            run.mkdir(parents=True, exist_ok=True)
            dump_config(cfg, run / "config.yaml")
        else:
            dump_config(cfg, run / "config.yaml")  # total_timesteps may have been raised
        t = Trainer(cfg, run, resume=resume, quiet=quiet, argv=argv)
        t.setup()
        try:
            return t.learn(callbacks)
        finally:
            t.close()
    finally:
        lock.release()


# --------------------------------------------------------------------------- command line
def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(
        prog="cepam-gym train",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--config", help="training config (YAML), e.g. configs/quick.yaml")
    ap.add_argument("--total-timesteps", type=int, help="override the config's total_timesteps")
    ap.add_argument("--seed", type=int, help="override the config's seed")
    ap.add_argument("--out", help="run directory (default runs/<config name>-s<seed>)")
    ap.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out (or the default directory) from its newest checkpoint",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    args = ap.parse_args(argv)
    if args.total_timesteps is not None and args.total_timesteps < 1:
        ap.error("--total-timesteps must be >= 1")
    if args.seed is not None and args.seed < 0:
        ap.error("--seed must be >= 0")
    try:
        if args.resume:
            from .policy import load_run_config

            if args.out is None and args.config is None:
                ap.error("--resume needs --out DIR (or --config to find the default directory)")
            if args.out is not None:
                run = Path(args.out)
            else:
                seed = args.seed if args.seed is not None else load_config(args.config).seed
                run = Path("runs") / f"{Path(args.config).stem}-s{seed}"
            if not (run / "config.yaml").is_file():
                ap.error(f"--resume: {run} is not a run directory (no config.yaml)")
            cfg = load_run_config(run)
            if args.seed is not None and args.seed != cfg.seed:
                ap.error(f"--resume: the run was seeded with {cfg.seed}, not {args.seed}")
        else:
            if args.config is None:
                ap.error("--config is required (e.g. configs/quick.yaml)")
            cfg = load_config(args.config)
            if args.seed is not None:
                cfg = cfg.replace(seed=args.seed)
            run = Path(args.out) if args.out else Path("runs") / f"{Path(args.config).stem}-s{cfg.seed}"
        if args.total_timesteps is not None:
            cfg = cfg.replace(total_timesteps=args.total_timesteps)
        return train(cfg, run, resume=args.resume, quiet=args.quiet, argv=["train", *argv])
    except KeyboardInterrupt:  # during start-up (learn() handles its own): nothing to save yet
        print(
            "cepam-gym train: interrupted before training started; nothing saved (the same command "
            "starts the run afresh)",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    except user_error_types() as e:  # bad config, env kwargs, hyperparameters, missing or corrupted files
        if debug_on():
            raise
        return report("cepam-gym train", e)


if __name__ == "__main__":
    raise SystemExit(main())
