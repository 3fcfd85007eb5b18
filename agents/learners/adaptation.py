"""RMA's second phase for a student told the plant: ``student.adaptation``, or an existing run's
``python -m cepam_gym_agents.learners.adaptation --run DIR``.

A student told the plant (``agent.plant_features``) tracks well when the plant it is told is
right: the true plant in training, the identification window's fit where a window runs. Where none
runs (the randomized suites themselves) this fits an adaptation module (Kumar et al. 2021): a
network from the last seconds of what the sensors read and the valves were sent
(:data:`cepam_gym.policies.plant_estimate.INPUTS`) to the plant's columns, by regression on
rollouts of the student itself on the student's suites' plants, whose true columns the simulator
knows. Round 0 the student is told the true plant; each later round it is told the module's
estimate and the histories it reaches are labelled with the true columns (DAgger, Ross et al.
2011). The module is saved beside the model as ``plant_estimator.npz`` (plain numpy deployed,
:class:`~cepam_gym.policies.plant_estimate.PlantEstimator`); a loaded run is told its estimate on
episodes without a window and the window's fit behind one.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from cepam_gym.policies.plant_estimate import INPUTS, InputFrames, PlantEstimator

from ..config.adaptation import AdaptationConfig
from ..config.files import ConfigError, TrainConfig

SAMPLE_EVERY = 5  # control steps between the rows kept of a rollout (neighbours are near copies)
BATCH = 512
LEARNING_RATE = 1e-3


def rollout(run: Path, suite: str, n: int, seed: int, estimator: PlantEstimator | None, history, stride):
    """One episode in ``n`` envs of ``suite``'s plants driven by the run's student, told the true
    plant (``estimator`` None) or the estimate: ``(inputs (rows, frames * inputs), true columns)``."""
    import gymnasium as gym

    from cepam_gym.bench.suites import SUITES
    from cepam_gym.control.baseline import rig_model_of
    from cepam_gym.identify.window_identifier import plant_columns

    from ..policy import load_policy

    s = SUITES[suite]
    venv = gym.make_vec(s.env_id, num_envs=n, **s.env_kwargs)
    try:
        policy = load_policy(run, venv, "final")
        if estimator is None:
            policy.features.use_true_plant()
        else:
            policy.features.plant_estimator = estimator
        rig = rig_model_of(venv)
        frames = InputFrames(rig.obs_layout, INPUTS, history, stride)
        obs, _ = venv.reset(seed=seed)
        policy.reset()
        xs, ys = [], []
        for t in range(rig.n_steps):
            x = frames.push(obs)
            if t % SAMPLE_EVERY == SAMPLE_EVERY - 1:
                xs.append(x)
                ys.append(plant_columns(rig.params, rig.nominal))
            obs, _r, term, trunc, _ = venv.step(policy.act(obs))
            if (term | trunc).any():  # one episode per env: a burst ends the rollout's rows
                break
        return np.concatenate(xs), np.concatenate(ys)
    finally:
        venv.close()


class _Net:
    def __init__(self, in_dim: int, out_dim: int, arch: list, seed: int):
        import torch

        torch.manual_seed(seed)
        layers, k = [], in_dim
        for w in arch:
            layers += [torch.nn.Linear(k, w), torch.nn.ELU()]
            k = w
        self.net = torch.nn.Sequential(*layers, torch.nn.Linear(k, out_dim))

    def fit(self, x, y, mean, std, steps: int, seed: int) -> float:
        """``steps`` Adam steps of the mean squared error of the columns; the last 100's mean."""
        import torch

        g = torch.Generator().manual_seed(seed)
        z = torch.as_tensor((x - mean) / std, dtype=torch.float32)
        t = torch.as_tensor(y, dtype=torch.float32)
        opt = torch.optim.Adam(self.net.parameters(), lr=LEARNING_RATE)
        losses = []
        for _ in range(steps):
            idx = torch.randint(len(z), (min(BATCH, len(z)),), generator=g)
            loss = ((self.net(z[idx]) - t[idx]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            losses.append(loss.item())
        return float(np.mean(losses[-100:]))

    def frozen(self, mean, std, low, high, history: int, stride: int) -> PlantEstimator:
        linear = [m for m in self.net if hasattr(m, "weight")]
        return PlantEstimator(
            history,
            stride,
            tuple(m.weight.detach().numpy().astype(np.float32).copy() for m in linear),
            tuple(m.bias.detach().numpy().astype(np.float32).copy() for m in linear),
            mean.astype(np.float32),
            std.astype(np.float32),
            low.astype(np.float32),
            high.astype(np.float32),
        )


def _control_dt(suite: str) -> float:
    import gymnasium as gym

    from cepam_gym.bench.suites import SUITES
    from cepam_gym.envs.model import model_of

    s = SUITES[suite]
    venv = gym.make_vec(s.env_id, num_envs=1, **s.env_kwargs)
    try:
        return float(model_of(venv).control_dt)
    finally:
        venv.close()


def fit_adaptation(cfg: TrainConfig, run: Path, settings: AdaptationConfig, say=print) -> dict:
    """Fit and save the run's adaptation module (its rounds' record: rows, loss, seconds)."""
    if not cfg.agent.plant_features or cfg.student is None:
        raise ConfigError(
            "an adaptation module estimates the plant a student is told: the run needs a student with "
            "agent.plant_features"
        )
    suites = sorted(cfg.student.suites.items())
    total = sum(n for _, n in suites)
    history = max(1, round(settings.history_s / _control_dt(suites[0][0])))
    xs, ys, rounds = [], [], []
    net = estimator = mean = std = None
    for r in range(settings.rounds):
        t0 = time.perf_counter()
        for k, (suite, count) in enumerate(suites):
            n = max(1, round(settings.envs * count / total))
            seed = 2_000_003 * (cfg.seed + 1) + 101 * r + k  # never the suites' or the DAgger rounds'
            x, y = rollout(run, suite, n, seed, estimator, history, settings.stride)
            xs.append(x)
            ys.append(y)
        x, y = np.concatenate(xs), np.concatenate(ys)
        if net is None:  # the inputs' statistics of the student told the true plant, then frozen
            mean, std = x.mean(0), x.std(0) + 1e-6
            net = _Net(x.shape[1], y.shape[1], settings.net_arch, cfg.seed)
        steps = settings.gradient_steps if r == 0 else max(1, settings.gradient_steps // 2)
        loss = net.fit(x, y, mean, std, steps, cfg.seed + r)
        estimator = net.frozen(mean, std, y.min(0), y.max(0), history, settings.stride)
        explained = float(1 - loss / max(float(y.var(0).mean()), 1e-12))
        seconds = round(time.perf_counter() - t0, 1)
        rounds.append({"round": r, "rows": len(x), "loss": loss, "seconds": seconds})
        say(f"adaptation round {r}: {len(x)} rows, loss {loss:.4f} ({explained:.0%} explained), {seconds} s")
    estimator.save(run / PlantEstimator.FILE)
    return {"rounds": rounds, "history_steps": history, "stride": settings.stride}


def main(argv: list[str] | None = None) -> int:
    """Fit the adaptation module of a trained run (its config's ``student.adaptation``, or
    ``--config``'s, or the defaults)."""
    from cepam_gym.cli_errors import CommandParser

    from ..config.files import load_config
    from ..policy import load_run_config

    ap = CommandParser(prog="python -m cepam_gym_agents.learners.adaptation", description=main.__doc__)
    ap.add_argument("--run", required=True, help="a run directory of a student told the plant")
    ap.add_argument("--config", help="take student.adaptation from this config (a shipped name or a file)")
    args = ap.parse_args(argv)
    run = Path(args.run)
    if not (run / "config.yaml").is_file():
        ap.error(f"{run} is not a run directory (no config.yaml)")
    cfg = load_run_config(run)
    settings = cfg.student.adaptation if cfg.student is not None else None
    if args.config:
        other = load_config(args.config).student
        settings = other.adaptation if other is not None else None
    t0 = time.perf_counter()
    record = fit_adaptation(cfg, run, settings or AdaptationConfig())
    print(f"{run / PlantEstimator.FILE}: {len(record['rounds'])} rounds in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
