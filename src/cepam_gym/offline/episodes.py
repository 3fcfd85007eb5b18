"""The transitions of a benchmark rollout, cut into episodes (pure numpy; no Minari here).

An :class:`EpisodeRecorder` is the ``observer`` of :func:`cepam_gym.bench.harness.record`: it sees
the batched env's reset and every step of the N episodes the benchmark scores, and keeps, per
episode, what an offline-RL dataset holds (Minari's layout: ``T + 1`` observations and infos,
``T`` actions, rewards, terminations and truncations).

An episode ends at its first termination (a burst bladder or a non-finite state: the steps the
batched env takes after it belong to an autoreset episode the benchmark does not score, so they
are dropped) or at the last step recorded, which is a truncation (the time limit, or a shorter
``max_steps``). Infos are the env's per-step scalars (the named reward terms, the plant and target
quantities the score is computed from, the termination code), SI units as the env reports them;
the reset row has no step yet, so its reward terms and termination code are 0.
"""

from __future__ import annotations

import numpy as np


def _scalars(info: dict) -> dict[str, np.ndarray]:
    """The per-env scalar columns of a vector env's info: no masks (``_key``), no nested dicts, no
    per-env vectors (``final_obs``)."""
    return {
        k: v for k, v in info.items() if not k.startswith("_") and isinstance(v, np.ndarray) and v.ndim == 1
    }


class EpisodeRecorder:
    """Collects the transitions of ``num_envs`` parallel episodes (one per env of the batch).
    ``plants`` (optional): a callable giving the batch's parameter rows (num_envs, N_PARAMS) once
    it is reset (the env's privileged ``EnvModel.params``); each episode then keeps its plant's
    row (``plant``), the truth an offline identification is scored against."""

    def __init__(self, num_envs: int, plants=None):
        self.num_envs = int(num_envs)
        self._plants_of = plants
        self._plants: np.ndarray | None = None
        self._obs: list[np.ndarray] = []  # (N, obs_dim) per time index, reset first
        self._actions: list[np.ndarray] = []
        self._rewards: list[np.ndarray] = []
        self._terms: list[np.ndarray] = []
        self._infos: list[dict[str, np.ndarray]] = []
        self._end = np.full(self.num_envs, -1)  # step index of each episode's termination, -1: none

    def start(self, obs, info) -> None:
        self._obs = [np.asarray(obs, dtype=np.float32).copy()]
        self._infos = [_scalars(info)]
        self._actions, self._rewards, self._terms = [], [], []
        self._end[:] = -1
        if self._plants_of is not None:
            self._plants = np.array(self._plants_of(), dtype=float, copy=True)

    def step(self, actions, obs, rewards, terminated, truncated, info) -> None:
        t = len(self._actions)
        # the actions the plant received: the env clips commands into its action space [-1, 1]
        self._actions.append(np.clip(np.asarray(actions, dtype=np.float32), -1.0, 1.0))
        src = info.get("final_info", info) if np.any(terminated | truncated) else info
        # same-step autoreset returns the next episode's first observation: the last one is here
        final = info.get("final_obs")
        self._obs.append(
            np.where(np.asarray(info.get("_final_obs", False))[..., None], final, obs).astype(np.float32)
            if final is not None
            else np.asarray(obs, dtype=np.float32).copy()
        )
        self._rewards.append(np.asarray(rewards, dtype=np.float64).copy())
        self._terms.append(np.asarray(terminated, dtype=bool).copy())
        self._infos.append(_scalars(src))
        fresh = np.asarray(terminated, dtype=bool) & (self._end < 0)
        self._end[fresh] = t

    def episodes(self) -> list[dict]:
        """One dict per env: ``observations (T+1, obs_dim)``, ``actions (T, 2)``, ``rewards``,
        ``terminations``, ``truncations`` (T,), ``infos`` ``{key: (T+1,)}``, and ``plant``
        (N_PARAMS,) when the recorder was given the plants."""
        if not self._actions:
            raise ValueError("no step recorded")
        steps = len(self._actions)
        keys = list(dict.fromkeys(k for row in self._infos[1:] for k in row))
        out = []
        for n in range(self.num_envs):
            last = self._end[n] if self._end[n] >= 0 else steps - 1
            T = int(last) + 1
            terminated = np.array([bool(self._terms[t][n]) for t in range(T)])
            truncations = np.zeros(T, dtype=bool)
            truncations[-1] = not terminated[-1]
            infos = {}
            for k in keys:
                first = self._infos[0].get(k)
                rows = [self._infos[t + 1].get(k) for t in range(T)]
                col = [first[n] if first is not None else 0] + [
                    r[n] if r is not None else np.nan for r in rows
                ]
                infos[k] = np.asarray(col)
            out.append(
                {
                    "observations": np.stack([self._obs[t][n] for t in range(T + 1)]),
                    "actions": np.stack([self._actions[t][n] for t in range(T)]),
                    "rewards": np.array([self._rewards[t][n] for t in range(T)]),
                    "terminations": terminated,
                    "truncations": truncations,
                    "infos": infos,
                    **({"plant": self._plants[n]} if self._plants is not None else {}),
                }
            )
        return out
