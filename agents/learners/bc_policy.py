"""A behaviour-cloning policy (Pomerleau 1991) as a benchmark controller: the MLP, its files and
``load_bc_policy(run_dir, env)``.

A BC run directory (written by ``python -m cepam_gym_agents.bc``) holds ``bc_policy.pt`` (the
weights and the observation standardization) and ``bc.json`` (what it was trained from and how it
scored). :func:`cepam_gym_agents.policy.load_policy`, the ``agent`` loader of trained agents,
hands such a directory here, so ``cepam-gym bench --controller DIR`` scores it like any agent.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cepam_gym.cli_errors import guarded_load
from cepam_gym.errors import InputError
from cepam_gym.policies import obs_batch

WEIGHTS = "bc_policy.pt"
INFO = "bc.json"
# a column nearly constant in the dataset (the supply pressure of a nominal plant) would be blown
# up by its tiny spread: the observations are scaled to about unit range, so 0.01 is small
STD_FLOOR = 0.01


def is_bc_run(path: str | Path) -> bool:
    return (Path(path) / WEIGHTS).is_file()


def make_mlp(obs_dim: int, act_dim: int, hidden: list[int]):
    """``obs_dim -> hidden... -> act_dim``, ReLU, and a tanh output: commands stay in [-1, 1]."""
    import torch.nn as nn

    layers, width = [], obs_dim
    for h in hidden:
        layers += [nn.Linear(width, h), nn.ReLU()]
        width = h
    layers += [nn.Linear(width, act_dim), nn.Tanh()]
    return nn.Sequential(*layers)


def save(out: Path, net, obs_mean: np.ndarray, obs_std: np.ndarray, hidden: list[int], info: dict) -> None:
    import torch

    out.mkdir(parents=True, exist_ok=True)
    torch.save(
        {
            "state_dict": net.state_dict(),
            "obs_mean": torch.as_tensor(obs_mean, dtype=torch.float32),
            "obs_std": torch.as_tensor(obs_std, dtype=torch.float32),
            "hidden": list(hidden),
        },
        out / WEIGHTS,
    )
    (out / INFO).write_text(json.dumps(info, indent=2) + "\n")


class BCPolicy:
    """Deterministic: ``act(obs)`` maps (N, obs_dim) -> (N, act_dim) float32 or (obs_dim,) ->
    (act_dim,). Memoryless (the dataset's observation is all it was trained on)."""

    def __init__(self, net, obs_mean, obs_std):
        import torch

        self.net = net.eval()
        self.mean = torch.as_tensor(obs_mean, dtype=torch.float32)
        self.std = torch.as_tensor(obs_std, dtype=torch.float32)
        self.obs_dim = int(self.mean.shape[0])

    def reset(self, indices=None) -> None:
        pass

    def act(self, obs, info=None) -> np.ndarray:
        import torch

        o, single = obs_batch(obs, self.obs_dim)
        with torch.no_grad():
            a = self.net((torch.from_numpy(o) - self.mean) / self.std).numpy()
        return a[0] if single else a


def load_bc_policy(spec: str | Path, env=None) -> BCPolicy:
    """The BC policy of a run directory, checked against ``env``'s observation size."""
    import torch

    path = Path(spec) / WEIGHTS
    if not path.is_file():
        raise FileNotFoundError(f"{spec} is not a behaviour-cloning run directory: no {WEIGHTS}")
    blob = guarded_load(
        path, "behaviour-cloning policy", torch.load, path, map_location="cpu", weights_only=True
    )
    mean, std = blob["obs_mean"], blob["obs_std"]
    net = make_mlp(int(mean.shape[0]), _act_dim(blob["state_dict"]), blob["hidden"])
    net.load_state_dict(blob["state_dict"])
    policy = BCPolicy(net, mean, std)
    if env is not None:
        space = getattr(env, "single_observation_space", None) or env.observation_space
        if tuple(space.shape[-1:]) != (policy.obs_dim,):
            raise InputError(
                f"behaviour-cloning policy {spec} takes observations of size {policy.obs_dim}, "
                f"the env gives {space.shape[-1]}: wrong env for this policy?"
            )
    return policy


def _act_dim(state_dict) -> int:
    last = [k for k in state_dict if k.endswith(".weight")][-1]
    return int(state_dict[last].shape[0])
