"""The SB3 algorithm a config names: its class (SAC, PPO, TD3, or sb3-contrib's RecurrentPPO), its
policy, which hyperparameters and policy kwargs it accepts (checked against its constructor when a
config is read), the constructor arguments built from those checked values, and the number of
steps its ``learn`` advances by at a time. It knows nothing of the config's schema, which reads it."""

from __future__ import annotations

import inspect
from typing import Any

from ..config.checks import ConfigError, as_bool, as_float, as_int, as_mapping

ALGORITHMS = ("SAC", "PPO", "TD3", "RecurrentPPO")
ON_POLICY = ("PPO", "RecurrentPPO")
# constructor arguments the trainer sets itself (or that cannot come from YAML)
_RESERVED = {
    "self",
    "policy",
    "env",
    "seed",
    "verbose",
    "tensorboard_log",
    "device",
    "policy_kwargs",
    "_init_setup_model",
    "replay_buffer_class",
    "rollout_buffer_class",
}
ACTIVATIONS = {
    "relu": "ReLU",
    "tanh": "Tanh",
    "elu": "ELU",
    "leaky_relu": "LeakyReLU",
    "gelu": "GELU",
    "silu": "SiLU",
}
NOISE_TYPES = ("normal", "ornstein_uhlenbeck")


def algorithm_class(name: str):
    """The SB3 (or sb3-contrib) class of an algorithm named in :data:`ALGORITHMS`."""
    if name == "RecurrentPPO":
        try:
            import sb3_contrib
        except ImportError:
            raise ConfigError(
                "algorithm RecurrentPPO needs sb3-contrib: pip install 'cepam-gym[train]' "
                "(or pip install sb3-contrib)"
            ) from None
        return sb3_contrib.RecurrentPPO
    import stable_baselines3 as sb3

    return getattr(sb3, name)


def training_class(algorithm: str, learner: str = "sb3"):
    """The class a session trains with: :func:`algorithm_class`, or for ``learner: native`` the
    PPO, RecurrentPPO, SAC or TD3 that collects from the vector env as arrays
    (:mod:`agents.learners.native_ppo`, ``native_recurrent``, ``native_offpolicy``; their models load as
    SB3's), with its gradient steps on the
    session's torch threads (:class:`~..session.torch_threads.ChosenThreadsTrain`)."""
    from ..session.torch_threads import with_chosen_threads

    if learner == "native":
        from .native_offpolicy import NativeSAC, NativeTD3
        from .native_ppo import NativePPO
        from .native_recurrent import NativeRecurrentPPO

        native = {"PPO": NativePPO, "RecurrentPPO": NativeRecurrentPPO, "SAC": NativeSAC, "TD3": NativeTD3}
        return with_chosen_threads(native[algorithm])
    return with_chosen_threads(algorithm_class(algorithm))


def policy_name(algorithm: str) -> str:
    """The policy alias the trainer asks the algorithm for: an LSTM policy for RecurrentPPO."""
    return "MlpLstmPolicy" if algorithm == "RecurrentPPO" else "MlpPolicy"


# --------------------------------------------------------------------------- checks (reading a config)
def check_hyperparameters(algorithm: str, hp: dict) -> dict:
    """Hyperparameters exist in the algorithm's constructor; numbers typed like its defaults."""
    cls = algorithm_class(algorithm)
    params = inspect.signature(cls.__init__).parameters
    valid = sorted(set(params) - _RESERVED)
    out = {}
    for key, value in hp.items():
        if key not in params or key in _RESERVED:
            why = " (set by the trainer or another section)" if key in _RESERVED else ""
            raise ConfigError(
                f"hyperparameters: unknown key {key!r} for {algorithm}{why}; valid keys: {valid}"
            )
        default = params[key].default
        where = f"hyperparameters.{key}"
        if key == "action_noise":
            out[key] = _check_noise(value, where)
        elif isinstance(default, bool):
            out[key] = as_bool(value, where)
        elif isinstance(default, int) and isinstance(value, (int, float)) and not isinstance(value, bool):
            out[key] = as_int(value, where)
        elif isinstance(default, float) and isinstance(value, (int, float)) and not isinstance(value, bool):
            out[key] = float(value)
        elif isinstance(default, (int, float)) and isinstance(value, str) and key != "ent_coef":
            raise ConfigError(f"{where} must be a number, got {value!r}")
        else:
            out[key] = value
    return out


def _check_noise(value: Any, where: str) -> dict | None:
    if value is None:
        return None
    d = as_mapping(value, where)
    bad = sorted(set(d) - {"type", "sigma"})
    if bad:
        raise ConfigError(f"{where}: unknown key {bad[0]!r}; valid keys: ['sigma', 'type']")
    kind = d.get("type", "normal")
    if kind not in NOISE_TYPES:
        raise ConfigError(f"{where}.type must be one of {NOISE_TYPES}, got {kind!r}")
    return {"type": kind, "sigma": as_float(d.get("sigma", 0.1), f"{where}.sigma", 0.0)}


def check_policy_kwargs(algorithm: str, pk: dict) -> dict:
    """Policy kwargs exist in the constructor of the algorithm's policy; ``activation_fn`` is named."""
    cls = algorithm_class(algorithm)
    policy_cls = cls.policy_aliases[policy_name(algorithm)]
    params = inspect.signature(policy_cls.__init__).parameters
    valid = sorted(set(params) - {"self", "observation_space", "action_space", "lr_schedule"})
    out = {}
    for key, value in pk.items():
        if key not in valid:
            raise ConfigError(
                f"policy_kwargs: unknown key {key!r} for {algorithm}'s {policy_name(algorithm)}; "
                f"valid keys: {valid}"
            )
        if key == "activation_fn":
            if value not in ACTIVATIONS:
                raise ConfigError(
                    f"policy_kwargs.activation_fn must be one of {sorted(ACTIVATIONS)}, got {value!r}"
                )
        out[key] = value
    return out


# --------------------------------------------------------------------------- constructor arguments
def hyperparameters(hp: dict) -> dict:
    """Checked hyperparameters (:func:`check_hyperparameters`) as the constructor takes them
    (action noise as an object)."""
    import numpy as np

    hp = dict(hp)
    noise = hp.pop("action_noise", None)
    if noise is not None:
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        cls = NormalActionNoise if noise["type"] == "normal" else OrnsteinUhlenbeckActionNoise
        hp["action_noise"] = cls(np.zeros(2), np.full(2, noise["sigma"]))
    if isinstance(hp.get("train_freq"), list):
        hp["train_freq"] = tuple(hp["train_freq"])
    return hp


def _policy_kwargs(pk: dict) -> dict:
    pk = dict(pk)
    if "activation_fn" in pk:
        import torch.nn

        pk["activation_fn"] = getattr(torch.nn, ACTIVATIONS[pk["activation_fn"]])
    return pk


def policy(algorithm: str, policy_kwargs: dict, privileged_critic: bool, env) -> tuple:
    """(policy, policy_kwargs) for the algorithm's constructor, from checked policy kwargs
    (:func:`check_policy_kwargs`): the asymmetric actor-critic when the critic is privileged (it
    is told how many input columns the actor may see)."""
    pk = _policy_kwargs(policy_kwargs)
    if not privileged_critic:
        return policy_name(algorithm), pk
    from .asymmetric import AsymmetricActorCriticPolicy

    return AsymmetricActorCriticPolicy, {**pk, "actor_dim": env.features.actor_dim}


def zero_output_layer(model) -> None:
    """Start ``model``'s deterministic policy at the action 0: the weights and bias of the linear
    layer that outputs the action (PPO's and RecurrentPPO's ``action_net``, SAC's mean, TD3's
    actor, each possibly followed by a squashing layer) set to zero, and TD3's target actor with
    it. The layers below still learn: their gradient flows once the first update has moved the
    output layer. SAC's spread (``log_std``) stays as built, so its samples still explore."""
    import torch

    p = model.policy
    out = p.action_net if hasattr(p, "action_net") else p.actor.mu  # SAC, TD3: Linear or Sequential
    layer = [m for m in out.modules() if isinstance(m, torch.nn.Linear)][-1]  # out itself if Linear
    with torch.no_grad():
        layer.weight.zero_()
        layer.bias.zero_()
    if getattr(p, "actor_target", None) is not None:
        p.actor_target.load_state_dict(p.actor.state_dict())


# --------------------------------------------------------------------------- how learn() advances
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


def collection_why(model) -> str:
    """Why :func:`steps_per_collection` is what it is, for the rounded-up-steps note."""
    n_envs = int(getattr(model, "n_envs", 1) or 1)
    if hasattr(model, "rollout_buffer"):
        return f"n_steps {model.n_steps} x {n_envs} envs"
    return f"{n_envs} envs per step"
