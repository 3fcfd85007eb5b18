"""A student distilled from a privileged teacher: ``cepam-gym train --config student``.

The teacher is any registered controller that reads what no rig has: the oracle (the schema's
default, :class:`cepam_gym.control.oracle.OracleController`: the true plant state, parameters,
load and reference horizon) or, in the shipped ``configs/student.yaml``, the MPC given each plant's
true parameters (``mpc_known_params``: privileged only in what a history can reveal, and smooth;
the oracle's labels follow hidden state and are noisy, and its student scored worse on both
suites: README, "Agents that adapt"; a teacher that reads the schedule plans the settling allowance
too, :func:`make_teacher`). The student sees only
the agent's features of the observation (:mod:`cepam_gym.policies`: an observation history, low-passed
copies). DAgger (Ross et al. 2011) trains it: round 0 records the teacher driving the envs; every
later round lets the student drive (the teacher taking over a step with probability ``beta``) and
asks the teacher what it would have sent in each state the student reached; the student is fitted
to all labels so far. This is the first phase of RMA (Kumar et al. 2021), with the history doing the
work of its adaptation module: the student cannot know the plant, it must infer what matters from
how the plant moved.

The envs are a mix of suites' plants (``student.suites``: nominal and randomized by default), with
episodes drawn from the run's seed (never the suites' own). The oracle's commands are small and
precise (standard deviation 0.03-0.06 of the valve range), so the fit regresses actions scaled by
their standard deviation. The student is saved as an SB3 PPO policy with its observation statistics
(``model.zip``, ``vecnormalize.pkl``), so ``eval``, ``bench``, ``video`` and the datasets load it as
any trained run; its value head is untrained (no RL fine-tuning: PPO continued from the student
scored worse on nominal-v1 and no better on randomized-v1, README).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from cepam_gym.policies import Features

from ..config.agent import feature_spec
from ..config.files import ConfigError, TrainConfig
from ..session.provenance import RunRecord, write_json
from ..session.torch_threads import TorchThreads

# VecNormalize's clip of normalized observations: the fit sees what the deployed policy will see
_CLIP_OBS = 10.0
# SB3's VecNormalize adds this to the variance
_VAR_EPS = 1e-8


def check_student(cfg: TrainConfig) -> None:
    """What a student needs of the rest of the config."""
    a = cfg.agent
    if a.target_shift or a.privileged_critic:
        raise ConfigError(
            "a student drives the valves from its features (or a residual on agent.base_controller): "
            "agent.target_shift and agent.privileged_critic do not apply"
        )
    if a.residual and a.residual_scale <= 0:
        raise ConfigError("a residual student needs agent.residual_scale > 0 (its labels are divided by it)")
    if not cfg.normalize.obs:
        raise ConfigError("a student normalizes its inputs: set normalize.obs: true")
    from cepam_gym.bench.suites import SUITES
    from cepam_gym.control import controller_names

    if cfg.student.teacher not in controller_names():
        raise ConfigError(
            f"student.teacher {cfg.student.teacher!r} is not a registered controller: "
            f"{', '.join(controller_names())}"
        )

    other = {s: SUITES[s].env_id for s in cfg.student.suites if SUITES[s].env_id != cfg.env.id}
    if other:
        raise ConfigError(
            f"student.suites must run env.id {cfg.env.id!r} (the student's observation): {other} do not"
        )
    if cfg.student.teacher_options:  # a misspelt option fails here, not after the first round
        _teacher_for_check(cfg)


def make_teacher(cfg: TrainConfig, venv):
    """The student's teacher on ``venv``: ``student.teacher`` built with ``student.teacher_options``.

    A teacher that reads the benchmark's schedule (the oracle and its variants) plans the settling
    allowance after a jump of the target too (``allowance_weight`` 1 unless the options set it).
    The score leaves those steps out, so the shipped oracle plans nothing there and its commands in
    them depend on where the allowance ends, which a student cannot see: taught by such labels, a
    student learns to lag the jumps (docs/results/agents.md, "The joint's agent")."""
    from cepam_gym.control import make_controller

    return make_controller(cfg.student.teacher, venv, **teacher_options(cfg))


def teacher_options(cfg: TrainConfig) -> dict:
    """``student.teacher_options``, with ``allowance_weight`` 1 for a teacher that reads the
    schedule (:func:`make_teacher`) where they do not set it."""
    from cepam_gym.control.oracle import OracleController
    from cepam_gym.control.registry import CONTROLLERS, load_factory

    options = dict(cfg.student.teacher_options)
    target = CONTROLLERS.get(cfg.student.teacher)
    factory = None if target is None else load_factory(target)
    reads_schedule = isinstance(factory, type) and issubclass(factory, OracleController)
    if reads_schedule and "allowance_weight" not in options:
        options["allowance_weight"] = TEACHER_ALLOWANCE_WEIGHT
    return options


# the weight a schedule-reading teacher gives the errors inside the settling allowance (the score: 0)
TEACHER_ALLOWANCE_WEIGHT = 1.0


def _teacher_for_check(cfg: TrainConfig) -> None:
    import gymnasium as gym

    from cepam_gym.bench.suites import SUITES

    s = SUITES[next(iter(cfg.student.suites))]
    venv = gym.make_vec(s.env_id, num_envs=1, **s.env_kwargs)
    try:
        make_teacher(cfg, venv)
    except (TypeError, ValueError) as e:
        teacher = cfg.student.teacher
        raise ConfigError(f"student.teacher_options do not fit teacher {teacher!r}: {e}") from None
    finally:
        venv.close()


class _Actor:
    """The student's MLP (tanh hidden layers, linear head on actions scaled by ``scale``)."""

    def __init__(self, in_dim: int, arch: list, seed: int):
        import torch

        torch.manual_seed(seed)
        layers, k = [], in_dim
        for w in arch:
            layers += [torch.nn.Linear(k, w), torch.nn.Tanh()]
            k = w
        self.body = torch.nn.Sequential(*layers)
        self.head = torch.nn.Linear(k, 2)
        self.params = list(self.body.parameters()) + list(self.head.parameters())

    def __call__(self, x):
        return self.head(self.body(x))


class Student:
    """The student acting during collection: features -> normalized -> MLP -> valve commands."""

    def __init__(self, actor: _Actor, mean, std, scale):
        self.actor, self.mean, self.std, self.scale = actor, mean, std, scale

    def __call__(self, x: np.ndarray) -> np.ndarray:
        import torch

        z = np.clip((x - self.mean) / self.std, -_CLIP_OBS, _CLIP_OBS)
        with torch.no_grad():
            a = self.actor(torch.as_tensor(z, dtype=torch.float32)).numpy()
        return np.clip(a * self.scale, -1.0, 1.0).astype(np.float32)


def collect(
    cfg: TrainConfig,
    suite: str,
    num_envs: int,
    seed: int,
    student=None,
    beta: float = 1.0,
    deadline: float | None = None,
):
    """One episode in each of ``num_envs`` envs of ``suite``'s plant: the features the student saw
    (T*N, dim) and the teacher's actions (T*N, 2) (with ``agent.residual``: what the teacher adds
    to the base controller, over ``residual_scale``). ``student``: a callable of features that
    drives (the teacher every step with probability ``beta``); None: the teacher drives.
    ``deadline`` (``time.perf_counter()``): the episodes stop at the first step past it, so a
    round never outlasts the run's time limit (the rows so far are labels like any other)."""
    import gymnasium as gym

    from cepam_gym.bench.suites import SUITES
    from cepam_gym.envs.model import model_of

    s = SUITES[suite]
    venv = gym.make_vec(s.env_id, num_envs=num_envs, **s.env_kwargs)
    try:
        teacher = make_teacher(cfg, venv)
        env_model = model_of(venv)
        features = Features(venv, feature_spec(cfg.agent), env_model.obs_dim)
        if features.plant_dim:  # the student is told the true plant (deployed: the window's fit)
            features.use_true_plant()
        rng = np.random.default_rng(seed)
        obs, info = venv.reset(seed=seed)
        teacher.reset()
        n_steps = env_model.n_steps
        xs, ys = [], []
        residual = cfg.agent.residual
        for _ in range(n_steps):
            x, base = features(obs)
            label = np.asarray(teacher.act(obs, info), dtype=np.float32)
            xs.append(x)
            # a residual student is fitted to what the teacher adds to its base controller
            ys.append((label - base) / cfg.agent.residual_scale if residual else label)
            act = label
            if student is not None:
                own = features.action(student(x), base) if residual else student(x)
                act = np.where((rng.random(num_envs) < beta)[:, None], label, own)
            obs, _r, term, trunc, info = venv.step(act)
            if (term | trunc).any():  # a burst bladder ends an episode early: its rows stop here
                break
            if deadline is not None and time.perf_counter() > deadline:
                break
        return np.concatenate(xs), np.concatenate(ys)
    finally:
        venv.close()


def fit(
    actor: _Actor, x, y, mean, std, scale, steps: int, batch: int, lr: float, seed: int, threads=None
) -> float:
    """``steps`` Adam steps (cosine-decayed) of the mean squared error on actions / ``scale``, each
    on ``threads`` (a :class:`~..session.torch_threads.TorchThreads`) when given; returns the last 100
    steps' mean loss."""
    import torch

    g = torch.Generator().manual_seed(seed)
    z = torch.as_tensor(np.clip((x - mean) / std, -_CLIP_OBS, _CLIP_OBS), dtype=torch.float32)
    t = torch.as_tensor(y / scale, dtype=torch.float32)
    opt = torch.optim.Adam(actor.params, lr=lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, steps)
    losses = []

    def step() -> None:
        idx = torch.randint(len(z), (min(batch, len(z)),), generator=g)
        loss = ((actor(z[idx]) - t[idx]) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        losses.append(loss.item())

    for _ in range(steps):
        if threads is None:
            step()
        else:
            threads.run(step)
    return float(np.mean(losses[-100:]))


def as_ppo(cfg: TrainConfig, actor: _Actor, mean, std, scale, seed: int):
    """The student as an SB3 PPO model and its VecNormalize (the format every run loader reads):
    the actor's layers copied into the policy network, the action scale folded into its head."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from ..session.envs import make_train_env

    env = VecNormalize(make_train_env(cfg, seed), norm_obs=True, norm_reward=False, clip_obs=_CLIP_OBS)
    env.obs_rms.mean = mean.astype(np.float64)
    env.obs_rms.var = np.maximum(std.astype(np.float64) ** 2 - _VAR_EPS, 0.0)
    env.training = False
    arch = list(cfg.student.net_arch)
    model = PPO(
        "MlpPolicy",
        env,
        seed=seed,
        device="cpu",
        policy_kwargs={"net_arch": {"pi": arch, "vf": [64, 64]}, "activation_fn": torch.nn.Tanh},
    )
    pi = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    mine = [m for m in actor.body if isinstance(m, torch.nn.Linear)]
    s = torch.as_tensor(scale, dtype=torch.float32)
    with torch.no_grad():
        for dst, src in zip(pi, mine, strict=True):
            dst.weight.copy_(src.weight)
            dst.bias.copy_(src.bias)
        model.policy.action_net.weight.copy_(actor.head.weight * s[:, None])
        model.policy.action_net.bias.copy_(actor.head.bias * s)
    return model, env


def _score_and_record(
    cfg: TrainConfig, run: Path, record, rounds: list, labels: int, t0: float, stopped: bool, say, adaptation
):
    """Score the saved student on the config's evaluation episodes beside the baseline, and write
    the run directory's evaluations, summary (with the adaptation module's rounds) and status."""
    from ..policy import baseline_score, evaluate, load_policy
    from ..session.envs import eval_env_spec

    env_id, kwargs, spec = eval_env_spec(cfg)
    metrics = evaluate(
        lambda venv: load_policy(run, venv, "final"), env_id, kwargs, cfg.eval.episodes, cfg.eval.seed, spec
    )
    wall = round(time.perf_counter() - t0, 1)
    baseline = baseline_score(env_id, kwargs, cfg.eval.episodes, cfg.eval.seed, spec)
    if baseline is not None:
        metrics["baseline_score"] = baseline
    summary = {"labels": labels, "rounds": rounds, "wall_s": wall, "eval": metrics}
    if adaptation is not None:
        summary["adaptation"] = adaptation
    write_json(run / "evaluations.json", [{"step": labels, **metrics}])
    write_json(run / "summary.json", {"steps": labels, **summary})
    status = "stopped_by_time_limit" if stopped else "finished"
    record.write(status, 0, steps=labels, wall_s=wall)
    beside = "" if baseline is None else f", the baseline {baseline:.4f} on the same episodes"
    say(f"{status} in {wall} s; eval score {metrics['score']:.4f}{beside} ({json.dumps(cfg.eval.suite)})")


def train_student(cfg: TrainConfig, run: Path, quiet: bool = False, argv=None) -> int:
    """DAgger rounds, then save and score the student (the run directory's usual files)."""

    from ..session.checkpoints import save_model

    check_student(cfg)
    threads = TorchThreads(cfg.torch_threads)
    st, t0 = cfg.student, time.perf_counter()
    record = RunRecord(run, cfg.seed, argv)
    record.write("running", 0)

    def say(msg: str) -> None:
        if not quiet:
            print(f"student {run.name}: {msg}", flush=True)

    xs: list = []
    ys: list = []
    actor = mean = std = scale = None
    rounds, stopped = [], False
    limit = cfg.time_limit_minutes
    # the time limit holds inside a round too: its episodes stop there, the round is fitted on
    # the labels so far, and the run ends (a grid's cells keep the same budget on any machine)
    deadline = None if limit is None else t0 + 60 * limit
    for it in range(st.iterations):
        tr = time.perf_counter()
        student = None if actor is None else Student(actor, mean, std, scale)
        for k, (suite, n) in enumerate(sorted(st.suites.items())):
            if deadline is not None and xs and time.perf_counter() > deadline:
                break  # the suites left of this round: past the limit
            # episodes of the run's own seed, a new one per round and suite (never the suites')
            seed = 1_000_003 * (cfg.seed + 1) + 101 * it + k
            x, y = collect(cfg, suite, n, seed, student, st.beta, deadline)
            xs.append(x)
            ys.append(y)
        x, y = np.concatenate(xs), np.concatenate(ys)
        labels_s = time.perf_counter() - tr
        late = deadline is not None and time.perf_counter() > deadline  # its episodes stopped at the limit
        if actor is None:  # statistics of the teacher's states, frozen like a deployed normalizer
            mean, std = x.mean(0), x.std(0) + 1e-3
            scale = y.std(0) + 1e-6
            actor = _Actor(x.shape[1], st.net_arch, cfg.seed)
        loss = fit(
            actor,
            x,
            y,
            mean,
            std,
            scale,
            st.gradient_steps,
            st.batch_size,
            st.learning_rate,
            cfg.seed + it,
            threads,
        )
        rounds.append(
            {
                "round": it,
                "labels": len(x),
                "loss": loss,
                "seconds": round(time.perf_counter() - tr, 1),
                "labels_s": round(labels_s, 1),  # the teacher's labels (and the student's driving)
                "past_time_limit": late,
            }
        )
        say(f"round {it}: {len(x)} labels, scaled loss {loss:.3f}, {rounds[-1]['seconds']} s")
        record.write("running", 0, rounds=rounds)
        if late or (deadline is not None and it + 1 < st.iterations and time.perf_counter() > deadline):
            stopped = True
            say(f"stopped by the time limit ({limit} min) in round {it + 1} of {st.iterations}")
            break
    model, vecnorm = as_ppo(cfg, actor, mean, std, scale, cfg.seed)
    save_model(run, "final", model, vecnorm)
    vecnorm.close()
    adaptation = _adapt(cfg, run, say)
    labels = int(sum(len(v) for v in xs))
    _score_and_record(cfg, run, record, rounds, labels, t0, stopped, say, adaptation)
    return 0


def _adapt(cfg: TrainConfig, run: Path, say) -> dict | None:
    """RMA's second phase (``student.adaptation``): the plant the student is told where no window
    runs; its rounds' record, or None without the section."""
    if cfg.student.adaptation is None:
        return None
    from .adaptation import fit_adaptation

    return fit_adaptation(cfg, run, cfg.student.adaptation, say)
