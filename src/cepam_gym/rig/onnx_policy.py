"""An exported policy (``cepam-gym export``) as a controller, run by onnxruntime (no torch).

:class:`OnnxPolicy` follows the controller protocol (``reset``, ``act``): ``act(obs)`` maps one
observation ``(obs_dim,)`` or a batch ``(N, obs_dim)`` to the env's actions. When the file stacks
a history it takes the stack as an explicit input and returns it updated; this class keeps it
between calls and starts each episode with copies of its first observation, as training did.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError

META_PREFIX = "cepam_gym."
DEPLOY_EXTRA = "pip install 'cepam-gym[deploy]'"


def _runtime():
    try:
        import onnxruntime
    except ImportError:
        raise InputError(f"running an ONNX policy needs onnxruntime: {DEPLOY_EXTRA}") from None
    return onnxruntime


class OnnxPolicy:
    """The policy in the ONNX file ``path``; ``meta`` holds its ``cepam_gym.*`` metadata (env id,
    env kwargs, action mode, observation width, history)."""

    def __init__(self, path: str | Path, threads: int = 1):
        ort = _runtime()
        path = Path(path)
        if not path.is_file():
            raise InputError(f"policy file {path} does not exist")
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = opts.inter_op_num_threads = int(threads)
        try:
            self.session = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
        except Exception as e:  # onnxruntime's own exception types: a file that is not a model
            raise InputError(f"{path} is not a loadable ONNX model ({type(e).__name__}: {e})") from None
        raw = self.session.get_modelmeta().custom_metadata_map
        self.meta = {k[len(META_PREFIX) :]: v for k, v in raw.items() if k.startswith(META_PREFIX)}
        inputs = {i.name: i for i in self.session.get_inputs()}
        if "obs" not in inputs:
            raise InputError(f"{path} was not written by cepam-gym export (no input 'obs')")
        self.obs_dim = int(inputs["obs"].shape[1])
        self.history = int(self.meta.get("history", 1))
        self.action_mode = self.meta.get("action_mode", "valve")
        self.env_id = self.meta.get("env_id") or None
        # None: the file does not say (exported from a bare model, without its run's config)
        self.env_kwargs = json.loads(self.meta["env_kwargs"]) if "env_kwargs" in self.meta else None
        self.path = path
        self._stack: np.ndarray | None = None

    def check_env(self, obs_dim: int, action_mode: str) -> None:
        """``InputError`` unless the policy reads ``obs_dim`` columns and sends ``action_mode``."""
        if obs_dim != self.obs_dim or action_mode != self.action_mode:
            raise InputError(
                f"{self.path} reads {self.obs_dim} observation columns in action mode {self.action_mode!r} "
                f"(trained on {self.env_id or 'an unnamed env'}); the env gives {obs_dim} columns in "
                f"{action_mode!r}: deploy it on the env it was trained on"
            )

    def reset(self, indices=None) -> None:
        if indices is None or self._stack is None:
            self._stack = None
        else:
            self._fresh[np.asarray(indices)] = True

    def act(self, obs, info=None) -> np.ndarray:
        o = np.asarray(obs, dtype=np.float32)
        single = o.ndim == 1
        o = np.atleast_2d(o)
        if o.shape[1] != self.obs_dim:
            raise InputError(
                f"observation must have shape ({self.obs_dim},) or (N, {self.obs_dim}), got {np.shape(obs)}"
            )
        if self.history == 1:
            (a,) = self.session.run(["action"], {"obs": o})
        else:
            if self._stack is None or self._stack.shape[0] != len(o):
                self._stack = np.repeat(o[:, None], self.history - 1, axis=1)
                self._fresh = np.zeros(len(o), dtype=bool)
            elif self._fresh.any():
                self._stack[self._fresh] = o[self._fresh, None]
                self._fresh[:] = False
            a, self._stack = self.session.run(["action", "history_out"], {"obs": o, "history": self._stack})
        return a[0] if single else a
