"""stable-baselines3 ``VecEnv`` over the native batched env: SB3 trains on N plants in one
process, one compiled kernel call per step. Needs the ``[train]`` extra (imported lazily)."""

from __future__ import annotations

from typing import Any

import numpy as np

try:
    from stable_baselines3.common.vec_env import VecEnv, VecMonitor
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "cepam_gym.integrations.sb3 needs stable-baselines3: pip install 'cepam-gym[train]' "
        "(install torch==2.13.0 first for the CPU build)"
    ) from e

from ..envs.cepam import CEPAMVectorEnv
from ..errors import InputError
from ..versions import RECOMMENDED_ID


class SB3VecEnv(VecEnv):
    """Adapts :class:`CEPAMVectorEnv` (Gymnasium vector API) to SB3. SB3 expects same-step
    autoreset (the last observation in ``info["terminal_observation"]``), so the vector env must
    be made with ``autoreset_mode="same_step"`` (:func:`make_sb3_vec_env` does). A finished env's
    info dict is its last step's (``final_info``), with ``termination_reason`` an integer code."""

    def __init__(self, venv: CEPAMVectorEnv):
        from gymnasium.vector import AutoresetMode

        if getattr(venv, "autoreset_mode", None) != AutoresetMode.SAME_STEP:
            raise InputError(
                "SB3VecEnv needs a vector env made with autoreset_mode='same_step', got "
                f"{getattr(venv, 'autoreset_mode', None)!r}"
            )
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions = None
        self._seeded_once = False

    def reset(self):
        seed = self._seeds[0] if self._seeds and self._seeds[0] is not None else None
        obs, _ = self.venv.reset(seed=seed)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions) -> None:
        self._actions = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)

    def step_wait(self):
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = terminated | truncated
        out = self._per_env(infos)
        if dones.any():
            final = self._per_env(infos["final_info"])
            for i in np.flatnonzero(dones):
                out[i] = final[i]
                out[i]["terminal_observation"] = infos["final_obs"][i]
                out[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), dones, out

    @staticmethod
    def _per_env(infos: dict) -> list[dict[str, Any]]:
        """Gymnasium's dict of arrays as SB3's list of per-env dicts (masked-out keys dropped)."""
        keys = [
            k
            for k, v in infos.items()
            if not k.startswith("_") and isinstance(v, np.ndarray) and v.dtype != object and k != "final_obs"
        ]
        full = [k for k in keys if "_" + k not in infos or infos["_" + k].all()]
        cols = [infos[k].tolist() for k in full]
        n = len(next(iter(infos.values()))) if infos else 0
        out: list[dict[str, Any]] = [dict(zip(full, vals)) for vals in zip(*cols)] or [{} for _ in range(n)]
        for k in keys:
            if k not in full:
                col = infos[k].tolist()
                for i in np.flatnonzero(infos["_" + k]):
                    out[i][k] = col[i]
        return out

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name, indices=None):
        return [getattr(self.venv, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name, value, indices=None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
        method = getattr(self.venv, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False for _ in self._get_indices(indices)]

    def get_images(self):
        frames = self.venv.render()
        return list(frames) if frames is not None else [None] * self.num_envs


def make_sb3_vec_env(
    env_id: str = RECOMMENDED_ID,
    num_envs: int = 8,
    seed: int | None = None,
    monitor: bool = True,
    **kwargs: Any,
):
    """SB3 VecEnv of ``num_envs`` plants of a registered id (``VecMonitor`` records episodes)."""
    import gymnasium as gym

    kwargs.setdefault("autoreset_mode", "same_step")  # SB3's convention (terminal_observation)
    venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)
    env = SB3VecEnv(venv.unwrapped if hasattr(venv, "unwrapped") else venv)
    if seed is not None:
        env.seed(seed)
    return VecMonitor(env) if monitor else env
