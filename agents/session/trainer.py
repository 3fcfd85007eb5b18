"""One training session of one run directory: :func:`train` (lock the directory, write its config,
run a :class:`Trainer`) and the :class:`Trainer` itself, which builds or resumes the model, runs
SB3's ``learn`` with the session's callback, evaluates and keeps the best model, and saves on a
stop (Ctrl-C, SIGTERM, the time limit) as at the end. The files it writes are listed in
:mod:`cepam_gym_agents.train`."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from cepam_gym.cli_errors import guarded_load
from cepam_gym.envs.model import model_of

from ..config.files import ConfigError, TrainConfig, dump_config
from ..learners.algorithm import (
    collection_why,
    hyperparameters,
    policy,
    steps_per_collection,
    training_class,
    zero_output_layer,
)
from .callbacks import make_callback_class
from .checkpoints import Checkpoints, save_model
from .envs import eval_env_spec, info_keys, make_train_env, normalize
from .lock import RunLock
from .progress import ProgressBar
from .provenance import RunRecord, now, write_json
from .signals import SigtermAsInterrupt, describe, exit_code
from .torch_threads import TorchThreads

# the periodic evaluation's metrics that go to TensorBoard and the CSV log
_LOGGED_METRICS = (
    "score",
    "length_rmse_mm",
    "stiffness_rmse_pct",
    "mean_return",
    "failure_rate",
    "settling_time_s",
)


def build_train_env(cfg: TrainConfig, seed: int):
    """The training env of ``cfg`` (:func:`~.envs.make_train_env`); a kwarg the env refuses (a
    missing plant file, a plant out of its ranges) is a ``ConfigError`` naming the env."""
    try:
        return make_train_env(cfg, seed)
    except (ValueError, TypeError, OSError) as e:
        raise ConfigError(f"env {cfg.env.id} (env.kwargs of the config): {e}") from e


def new_model(cfg: TrainConfig, algo, raw) -> tuple:
    """``(env, model)``: a fresh model of ``algo`` on ``raw`` in the config's normalization; the
    algorithm's refusal of its hyperparameters or policy_kwargs is a ``ConfigError``."""
    env = normalize(raw, cfg)
    try:
        pol, pk = policy(cfg.algorithm, cfg.policy_kwargs, cfg.agent.privileged_critic, raw)
        hp = hyperparameters(cfg.hyperparameters)
        model = algo(pol, env, seed=cfg.seed, verbose=0, device="cpu", policy_kwargs=pk, **hp)
    except (AssertionError, ValueError, TypeError) as e:  # SB3 checks its arguments with asserts
        raise ConfigError(
            f"{cfg.algorithm} rejected the hyperparameters {cfg.hyperparameters} "
            f"or policy_kwargs {cfg.policy_kwargs}: {e}"
        ) from e
    if cfg.agent.start_at_base:
        zero_output_layer(model)
    return env, model


def check(cfg: TrainConfig) -> None:
    """What ``cepam-gym train --check`` runs: every check a session makes before its first step
    (the training env with its kwargs and plant, the model with its hyperparameters, the periodic
    evaluation's env), building each once and writing nothing."""
    import gymnasium as gym

    raw = build_train_env(cfg, cfg.seed)
    try:
        if cfg.student is None:
            new_model(cfg, training_class(cfg.algorithm, cfg.learner), raw)
        eval_id, eval_kwargs, _ = eval_env_spec(cfg)
        try:
            gym.make_vec(eval_id, num_envs=1, **eval_kwargs).close()
        except (ValueError, TypeError, OSError) as e:
            raise ConfigError(f"the evaluation env {eval_id} (eval.suite of the config): {e}") from e
    finally:
        raw.close()


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
        self.checkpoints = Checkpoints(self.run, cfg.checkpoint.keep, cfg.checkpoint.replay_buffer)
        self.record = RunRecord(self.run, cfg.seed, argv)
        self.progress = ProgressBar(cfg.total_timesteps, f"{cfg.algorithm} {self.run.name}", quiet)
        self.best_score = float("inf")
        self.last_score: float | None = None
        self.baseline_score: float | None = None  # measured at the first evaluation
        self._baseline_measured = False
        self.evaluations: list[dict] = []
        self.stopped_by_time = False
        self.wall_before = 0.0
        self.t0 = time.perf_counter()

    # ----------------------------------------------------------------- set-up
    def setup(self) -> None:
        from stable_baselines3.common.logger import Logger, make_output_format

        cfg = self.cfg
        threads = TorchThreads(cfg.torch_threads)
        self.run.mkdir(parents=True, exist_ok=True)
        self.checkpoints.dir.mkdir(exist_ok=True)
        algo = training_class(cfg.algorithm, cfg.learner)
        candidates = self.checkpoints.resumable() if self.resume else []
        if self.resume and not candidates:
            self._say(
                f"{self.run}: no saved model to resume (killed during start-up?): starting afresh", err=True
            )
            self.resume = False
        latest = candidates[0] if candidates else None
        start = int(latest["steps"]) if latest else 0
        # a resumed session draws new episodes: seed + steps done
        seed = cfg.seed + start
        raw = env = build_train_env(cfg, seed)
        if latest:
            env, self.model, latest = self.checkpoints.load_newest(candidates, raw, cfg, algo, self._say)
            self._restore(latest, seed)
        else:
            env, self.model = new_model(cfg, algo, raw)
        self.model.torch_threads = threads
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
        env_model = model_of(raw)  # through the SB3 adapter to the vector env's plant model
        self.track_stiffness = env_model.track_stiffness
        self.contract = env_model.contract
        self.info_keys = info_keys(self.contract)
        self.eval_id, self.eval_kwargs, self.eval_traces = eval_env_spec(cfg)
        self.record.write("running", self.start_step)

    def _restore(self, latest: dict, seed: int) -> None:
        """A resumed session: the replay buffer, the random state, the evaluations so far, the wall time."""
        from stable_baselines3.common.utils import set_random_seed

        if latest.get("replay_buffer") and hasattr(self.model, "load_replay_buffer"):
            buf = self.run / latest["replay_buffer"]
            guarded_load(buf, "replay buffer", self.model.load_replay_buffer, str(buf))
        set_random_seed(seed)
        evals = self.run / "evaluations.json"
        if evals.is_file():
            self.evaluations = guarded_load(evals, "evaluation log", lambda: json.loads(evals.read_text()))
            scores = [e["score"] for e in self.evaluations if e.get("score") is not None]
            self.best_score = min(scores, default=float("inf"))
            self.last_score = scores[-1] if scores else None
        self.wall_before = float(latest.get("wall_s", 0.0))

    # ----------------------------------------------------------------- evaluation and saving
    def evaluate(self, n: int) -> dict:
        from cepam_gym.policies import Features

        from ..config.agent import feature_spec
        from ..policy import AgentPolicy, evaluate

        cfg = self.cfg
        normalizer = self.vecnorm if (self.vecnorm is not None and cfg.normalize.obs) else None

        def make(venv):
            return AgentPolicy(
                self.model, Features(venv, feature_spec(cfg.agent), model_of(venv).obs_dim), normalizer
            )

        t = time.perf_counter()
        m = evaluate(make, self.eval_id, self.eval_kwargs, cfg.eval.episodes, cfg.eval.seed, self.eval_traces)
        m = {
            "step": int(n),
            "wall_s": round(self.wall(), 2),
            "eval_s": round(time.perf_counter() - t, 2),
            **m,
        }
        if not self._baseline_measured:
            self.baseline_score, self._baseline_measured = self._baseline_score(), True
        if self.baseline_score is not None:
            m["baseline_score"] = self.baseline_score
        self.evaluations.append(m)
        write_json(self.run / "evaluations.json", self.evaluations)
        for k in _LOGGED_METRICS:
            if m.get(k) is not None:
                self.model.logger.record(f"eval/{k}", m[k])
        self.last_score = m["score"]
        if m["score"] < self.best_score:
            self.best_score = m["score"]
            save_model(self.run, "best", self.model, self.vecnorm)
            write_json(self.run / "best.json", {"step": int(n), **m})
        self.model.logger.record("eval/best_score", self.best_score)
        self.progress.baseline = self.baseline_score
        self.progress.score(self.last_score, self.best_score)
        return m

    def _baseline_score(self) -> float | None:
        from ..policy import baseline_score

        cfg = self.cfg
        score = baseline_score(
            self.eval_id, self.eval_kwargs, cfg.eval.episodes, cfg.eval.seed, self.eval_traces
        )
        if score is None:
            self._say(
                "note: the baseline cannot drive the evaluation env: no score beside the agent's", err=True
            )
        return score

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.t0

    def save_checkpoint(self, n: int, interrupted: bool = False) -> Path:
        return self.checkpoints.save(self.model, self.vecnorm, n, round(self.wall(), 2), interrupted)

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
        cb = CallbackList([make_callback_class()(self), *callbacks])
        chunk = steps_per_collection(self.model)
        planned = -(-remaining // chunk) * chunk
        if planned != remaining:
            self._say(
                f"note: {cfg.algorithm} collects {chunk} steps at a time ({collection_why(self.model)}): "
                f"training {planned} steps, not {remaining} (total {self.start_step + planned})",
                err=True,
            )
        self.record.write("running", self.start_step, requested_steps=remaining, planned_steps=planned)
        self._say(
            f"training {cfg.algorithm} on {cfg.env.id} x{cfg.env.num_envs} for {planned} steps "
            f"(from step {self.start_step}) -> {self.run}"
        )
        with SigtermAsInterrupt() as sigterm:
            try:
                self.model.learn(
                    remaining,
                    callback=cb,
                    reset_num_timesteps=not self.resume or self.start_step == 0,
                    progress_bar=False,
                )
            except KeyboardInterrupt as e:
                sigterm.ignore()  # a second SIGTERM must not cut the save
                return self._interrupted(e)
        return self._finish()

    def _interrupted(self, stop: KeyboardInterrupt) -> int:
        n = int(self.model.num_timesteps)
        self.progress.close()
        path = self.save_checkpoint(n, interrupted=True)
        how = describe(stop)
        self.record.write(
            "interrupted", self.start_step, end_step=n, wall_s=round(self.wall(), 2), ended=now(), signal=how
        )
        self._say(
            f"{how} at step {n}: saved {path}; continue with cepam-gym train --out {self.run} --resume",
            err=True,
        )
        return exit_code(stop)

    def _finish(self) -> int:
        cfg = self.cfg
        n = int(self.model.num_timesteps)
        self.evaluate(n)
        self.model.logger.dump(n)
        self.progress.close()
        save_model(self.run, "final", self.model, self.vecnorm)
        self.save_checkpoint(n)
        summary = {
            "steps": n,
            "wall_s": round(self.wall(), 2),
            "stopped_by_time_limit": self.stopped_by_time,
            "best_score": self.best_score,
            "final_score": self.last_score,
            "best": json.loads((self.run / "best.json").read_text()),
        }
        write_json(self.run / "summary.json", summary)
        status = "stopped_by_time_limit" if self.stopped_by_time else "finished"
        self.record.write(
            status,
            self.start_step,
            end_step=n,
            wall_s=round(self.wall(), 2),
            ended=now(),
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

    def _say(self, msg: str, err: bool = False) -> None:
        if err:  # warnings and stops: shown even with --quiet
            print(msg, file=sys.stderr, flush=True)
        elif not self.quiet:
            print(msg, flush=True)

    def close(self) -> None:
        self.progress.close()
        self.env.close()


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
                if Checkpoints(run, cfg.checkpoint.keep, cfg.checkpoint.replay_buffer).resumable():
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
        if cfg.student is not None:  # distilled from a teacher (DAgger), no RL loop to resume
            from ..learners.student import train_student

            if resume:
                raise ConfigError(f"{run}: a student run cannot be resumed; train it again with --out")
            return train_student(cfg, run, quiet=quiet, argv=argv)
        t = Trainer(cfg, run, resume=resume, quiet=quiet, argv=argv)
        t.setup()
        try:
            return t.learn(callbacks)
        finally:
            t.close()
    finally:
        lock.release()
