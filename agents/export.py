"""``cepam-gym export --run DIR --out policy.onnx``: a trained agent as one ONNX file that maps an
env observation to the env's action, everything the agent does in between inside the graph.

The graph holds, in the order :class:`~cepam_gym_agents.policy.AgentPolicy` runs them:

* the history stack (``agent.history`` > 1): the last ``history - 1`` observations are an explicit
  input ``history`` (batch, history - 1, obs_dim) and the updated stack an output ``history_out``,
  so the file itself keeps no state; at an episode's start the caller fills ``history`` with
  copies of the first observation, as training did (:class:`cepam_gym.rig.OnnxPolicy` does);
* the privileged critic's columns (``agent.privileged_critic``), NaN as deployed: the actor masks
  them;
* the observation normalisation (SB3's ``VecNormalize`` statistics), in float64 as SB3 computes it;
* the network's deterministic action (PPO and the student: the Gaussian's mean; SAC, TD3: the
  squashed actor), the action-space map SB3's ``predict`` applies (unscaling of a squashed output,
  else the clip to the action space) and the clip to [-1, 1] of the agent's action.

Inputs ``obs`` (batch, obs_dim) float32 and (with history) ``history``; outputs ``action``
(batch, 2) float32 in [-1, 1] (the env's action: what a rig's valve commands are, as in
``identify``'s logs) and (with history) ``history_out``. The file's metadata
(``cepam_gym.*`` keys) names the env id, its kwargs, the action mode and the shapes.

Refused with one line (``InputError``): recurrent policies (RecurrentPPO: its LSTM state), and
agents with a controller in the loop (``residual``, ``target_shift``, ``baseline_in_obs``,
``setpoint_gaps_in_obs``: the baseline is numpy code with its own state), observation filters
(``obs_filters_s``) and agents told the identified plant (``plant_features``: a fit per
episode). Those deploy by running the controller (``cepam-gym deploy``), not a file.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from cepam_gym.cli_errors import CommandParser
from cepam_gym.errors import InputError

OPSET = 17
META_PREFIX = "cepam_gym."


def _refusal(cfg, algorithm: str) -> str | None:
    """Why the agent cannot be one graph, or None."""
    if algorithm == "RecurrentPPO":
        return (
            "a recurrent policy (RecurrentPPO) carries its LSTM state between steps; exporting it is "
            "not supported: deploy an MLP agent (PPO, SAC, TD3, the student)"
        )
    if cfg is None:
        return None
    a = cfg.agent
    in_loop = [
        name
        for name, on in (
            ("residual", a.residual),
            ("target_shift", a.target_shift),
            ("baseline_in_obs", a.baseline_in_obs),
            ("setpoint_gaps_in_obs", a.setpoint_gaps_in_obs),
            ("load_estimate_in_obs", a.load_estimate_in_obs),
        )
        if on
    ]
    if a.plant_features:
        return (
            "the agent is told the plant its identification window's fit finds (agent.plant_features): "
            "the fit is not a network; exporting it is not supported (run it through Python: "
            "cepam-gym bench --controller RUN_DIR)"
        )
    if in_loop:
        return (
            f"the agent runs the controller {a.base_controller!r} in its loop "
            f"(agent.{', agent.'.join(in_loop)}), "
            "which is not a network; exporting it is not supported (deploy the run with its controller "
            "through Python instead)"
        )
    if a.obs_filters_s:
        return "the agent low-passes its observations (agent.obs_filters_s): that state is not exported"
    return None


def _graph_module(model, normalizer, history: int, raw_dim: int, priv_dim: int):
    import torch

    policy = model.policy
    policy.set_training_mode(False)
    space = model.action_space
    low = torch.as_tensor(space.low, dtype=torch.float32)
    high = torch.as_tensor(space.high, dtype=torch.float32)
    squash = bool(getattr(policy, "squash_output", False))
    if normalizer is not None:
        mean = torch.as_tensor(np.asarray(normalizer.obs_rms.mean, dtype=np.float64))
        std = torch.as_tensor(
            np.sqrt(np.asarray(normalizer.obs_rms.var, dtype=np.float64) + normalizer.epsilon)
        )
        clip_obs = float(normalizer.clip_obs)
    else:
        mean = std = None
        clip_obs = 0.0

    class Exported(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.policy = policy

        def forward(self, obs, stack=None):
            f = obs
            new_stack = None
            if history > 1:
                f = torch.cat([stack.reshape(obs.shape[0], -1), obs], dim=1)
                new_stack = torch.cat([stack[:, 1:], obs[:, None]], dim=1)
            if priv_dim:
                f = torch.cat([f, torch.full((obs.shape[0], priv_dim), float("nan"))], dim=1)
            if mean is not None:
                f = torch.clamp((f.double() - mean) / std, -clip_obs, clip_obs).float()
            a = self.policy._predict(f, deterministic=True)
            a = low + 0.5 * (a + 1.0) * (high - low) if squash else torch.maximum(torch.minimum(a, high), low)
            a = torch.clamp(a, -1.0, 1.0)
            return a if new_stack is None else (a, new_stack)

    return Exported()


def export(run: str | Path, out: str | Path, which: str = "auto") -> dict:
    """Write the agent of ``run`` (a run directory, an RL Zoo3 run or a model ``.zip``) to the ONNX
    file ``out``; returns the metadata written into it."""
    import torch

    from cepam_gym.cli_errors import guarded_load

    from .config.files import algorithm_class
    from .policy import _normalizer, load_run_config, locate
    from .session.model_files import algorithm_of

    files = locate(run, which)
    cfg = load_run_config(files.run) if files.run is not None else None
    algorithm = cfg.algorithm if cfg is not None else algorithm_of(files.model)
    why = _refusal(cfg, algorithm)
    if why:
        raise InputError(f"cannot export {run}: {why}")
    model = guarded_load(
        files.model, f"{algorithm} model", algorithm_class(algorithm).load, str(files.model), device="cpu"
    )
    normalizer = _normalizer(files, cfg)
    history = cfg.agent.history if cfg is not None else 1
    width = int(model.observation_space.shape[0])
    priv_dim = width - _actor_width(model, width) if cfg is not None and cfg.agent.privileged_critic else 0
    if (width - priv_dim) % history:
        raise InputError(
            f"cannot export {run}: model input width {width} is not {history} stacked observations"
        )
    raw_dim = (width - priv_dim) // history
    graph = _graph_module(model, normalizer, history, raw_dim, priv_dim)
    obs = torch.zeros(1, raw_dim)
    args: tuple = (obs,)
    names_in, names_out = ["obs"], ["action"]
    axes = {"obs": {0: "batch"}, "action": {0: "batch"}}
    if history > 1:
        args = (obs, torch.zeros(1, history - 1, raw_dim))
        names_in.append("history")
        names_out.append("history_out")
        axes.update(history={0: "batch"}, history_out={0: "batch"})
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    # the TorchScript exporter (no onnxscript needed) warns that it is the older one, and the tracer
    # that SB3's distribution checks its arguments once (a constant of the trace, as it should be)
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", torch.jit.TracerWarning)
        torch.onnx.export(
            graph,
            args,
            str(out),
            input_names=names_in,
            output_names=names_out,
            dynamic_axes=axes,
            opset_version=OPSET,
            dynamo=False,
        )
    meta = {
        "obs_dim": raw_dim,
        "history": history,
        "algorithm": algorithm,
        "env_id": (cfg.env.id if cfg is not None else files.env_id()) or "",
        "action_mode": (dict(cfg.env.kwargs) if cfg is not None else {}).get("action_mode", "valve"),
        "normalized": bool(normalizer is not None),
        "source": str(files.model),
    }
    if cfg is not None:  # without a run config the training env's kwargs are unknown: none written
        meta["env_kwargs"] = json.dumps(dict(cfg.env.kwargs))
    _write_metadata(out, meta)
    return meta


def _actor_width(model, width: int) -> int:
    """The columns the actor reads (an asymmetric policy's ``actor_dim``, else all)."""
    return int(getattr(model.policy, "actor_dim", width))


def _write_metadata(path: Path, meta: dict) -> None:
    try:
        import onnx
    except ImportError:
        raise InputError("cepam-gym export needs the onnx package: pip install 'cepam-gym[train]'") from None
    from cepam_gym import __version__

    m = onnx.load(str(path))
    del m.metadata_props[:]
    for k, v in {**meta, "version": __version__}.items():
        entry = m.metadata_props.add()
        entry.key, entry.value = META_PREFIX + k, str(v)
    onnx.save(m, str(path))


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(
        prog="cepam-gym export",
        description="write a trained agent as one ONNX file (normalisation, history, clipping and "
        "action map inside); run it with onnxruntime (the [deploy] extra) or cepam-gym deploy",
    )
    ap.add_argument(
        "--run", required=True, help="run directory of cepam-gym train, RL Zoo3 run, or model .zip"
    )
    ap.add_argument("--out", required=True, help="the ONNX file to write")
    ap.add_argument("--model", default="auto", choices=("auto", "best", "final", "latest"))
    args = ap.parse_args(argv)
    meta = export(args.run, args.out, args.model)
    hist = f", history {meta['history']}" if meta["history"] > 1 else ""
    print(
        f"wrote {args.out}: {meta['algorithm']} on {meta['env_id'] or 'an unnamed env'} "
        f"({meta['obs_dim']} observation columns{hist}, action mode {meta['action_mode']})"
    )
    return 0
