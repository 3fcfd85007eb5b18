"""The training config's ``agent`` section: what the policy sees and sends on top of the env's own
observation and action (:class:`AgentConfig`, parsed and checked by ``AgentConfig.parse``)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

from cepam_gym.policies import FeatureSpec

from .checks import ConfigError, as_bool, as_float, as_int, as_mapping, check_keys


def _filters(value: Any, where: str) -> list:
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f"{where} must be a list of time constants in seconds, got {value!r}")
    out = [as_float(v, f"{where}[{i}]", 0.0) for i, v in enumerate(value)]
    if any(v <= 0 for v in out):
        raise ConfigError(f"{where}: time constants must be > 0 s, got {value!r}")
    return out


def _controller(name: Any, where: str) -> str:
    """A registered controller's name (``cepam_gym.control.controller_names``)."""
    from cepam_gym.control import controller_names

    if not isinstance(name, str) or name not in controller_names():
        raise ConfigError(
            f"{where} must be a registered controller ({', '.join(controller_names())}), got {name!r}"
        )
    return name


@dataclass(frozen=True)
class AgentConfig:
    """What the policy sees and sends, on top of the inverse-model baseline
    (:class:`cepam_gym.control.InverseStaticController`, nominal model):

    * ``target_shift``: the policy's first actions move the targets the baseline is given: the
      length by up to ``target_shift_length_mm`` (on the hinge ids the joint angle by up to
      ``target_shift_angle_deg``), the stiffness by a factor up to
      ``exp(+-target_shift_stiffness)`` (length-only tasks: the length shift only), low-pass
      filtered with time constant ``target_shift_filter_s`` if > 0. The baseline then computes
      pressures and valve commands for the shifted targets.
    * ``residual``: the policy's (remaining) two actions are added to the valve commands:
      ``clip(baseline + residual_scale * a, -1, 1)``.
    * ``start_at_base`` (with ``residual`` or ``target_shift``): the policy's output layer starts
      at zero, so the untrained agent's deterministic action (its mean) is its base controller's
      and its evaluations start from the base's score (residual policy learning, Silver et al.
      2018); SAC's and PPO's samples still spread around it as built.
    * ``baseline_in_obs``: the baseline's action is appended to the observation (not with
      ``target_shift``: the baseline acts only after the policy has chosen the shift).
    * ``setpoint_gaps_in_obs``: the gaps between the baseline's set-point pressures (the nominal
      inverse static model at its load estimate) and the measured ones are appended, in units of
      100 kPa: what the model says each chamber still needs (same restriction).
    * ``friction_observer``: the baseline's load estimate balances its friction elements' force
      too, tracked from the measured length (``baseline_friction``,
      :mod:`cepam_gym.control.friction_observer`), so its set-points (and gaps) are friction-aware.
    * ``base_controller``: the registered controller (``cepam_gym.control``) that ``residual`` and
      ``baseline_in_obs`` act on, default ``baseline``; another one (e.g. ``mpc_friction``) takes
      neither ``target_shift``, ``setpoint_gaps_in_obs`` nor ``friction_observer`` (they need the
      baseline's set-points).
    * ``history``: the last ``history`` observations are stacked.
    * ``obs_filters_s``: low-passed copies of the observation (one per time constant, seconds,
      restarted with each episode) are appended: a cheap memory over seconds.
    * ``privileged_critic`` (PPO): an asymmetric actor-critic (Pinto et al. 2018). During training
      the critic also sees what only the simulator knows (:mod:`cepam_gym.policies.privileged`: the true plant
      parameters, the load, the true errors); the actor's input masks those columns out, and a
      deployed policy is given NaN there (:mod:`agents.learners.asymmetric`).
    * ``plant_features``: the actor is told the plant (an adaptive agent in the manner of RMA,
      Kumar et al. 2021, its adaptation module the project's identification): the log ratios to
      the nominal plant of the parameter columns the identification window's fit moves
      (:func:`cepam_gym.identify.window_identifier.plant_columns`). Training reads the true
      plant; deployed, the agent plays the window's excitation and is told its fit, so it runs
      only on envs with an identification window (``randomized-id-v2``).
    * ``load_estimate_in_obs``: the adaptive MPC's filtered load estimate (an extended Kalman
      filter on the end cap's equation of motion, sensors only) and the nominal model's set-point
      gaps at that load are appended to each frame (:mod:`cepam_gym.policies.load_estimate`): what
      ``adaptive_mpc`` knows that a few frames do not show. The rig's ids only.

    With neither ``target_shift`` nor ``residual`` the policy drives the valves directly."""

    residual: bool = False
    residual_scale: float = 0.5
    baseline_in_obs: bool = False
    setpoint_gaps_in_obs: bool = False
    history: int = 1
    target_shift: bool = False
    target_shift_length_mm: float = 5.0
    target_shift_angle_deg: float = 2.0
    target_shift_stiffness: float = 0.4
    target_shift_filter_s: float = 0.0  # first-order low-pass of the shifts (0: none) [s]
    obs_filters_s: list = field(
        default_factory=list
    )  # time constants [s] of low-passed copies of the observation
    privileged_critic: bool = False
    friction_observer: bool = False
    base_controller: str = "baseline"
    plant_features: bool = False
    start_at_base: bool = False
    load_estimate_in_obs: bool = False

    @property
    def uses_baseline(self) -> bool:
        return feature_spec(self).uses_baseline

    @classmethod
    def parse(cls, data: Any) -> AgentConfig:
        d = as_mapping(data, "agent")
        check_keys(d, cls, "agent")
        out = cls(
            as_bool(d.get("residual", False), "agent.residual"),
            as_float(d.get("residual_scale", 0.5), "agent.residual_scale", 0.0),
            as_bool(d.get("baseline_in_obs", False), "agent.baseline_in_obs"),
            as_bool(d.get("setpoint_gaps_in_obs", False), "agent.setpoint_gaps_in_obs"),
            as_int(d.get("history", 1), "agent.history", 1),
            as_bool(d.get("target_shift", False), "agent.target_shift"),
            as_float(d.get("target_shift_length_mm", 5.0), "agent.target_shift_length_mm", 0.0),
            as_float(d.get("target_shift_angle_deg", 2.0), "agent.target_shift_angle_deg", 0.0),
            as_float(d.get("target_shift_stiffness", 0.4), "agent.target_shift_stiffness", 0.0),
            as_float(d.get("target_shift_filter_s", 0.0), "agent.target_shift_filter_s", 0.0),
            _filters(d.get("obs_filters_s", []), "agent.obs_filters_s"),
            as_bool(d.get("privileged_critic", False), "agent.privileged_critic"),
            as_bool(d.get("friction_observer", False), "agent.friction_observer"),
            _controller(d.get("base_controller", "baseline"), "agent.base_controller"),
            as_bool(d.get("plant_features", False), "agent.plant_features"),
            as_bool(d.get("start_at_base", False), "agent.start_at_base"),
            as_bool(d.get("load_estimate_in_obs", False), "agent.load_estimate_in_obs"),
        )
        if out.start_at_base and not (out.residual or out.target_shift):
            raise ConfigError(
                "agent.start_at_base starts the policy at its base controller, which only a residual "
                "or a target shift has: set agent.residual or agent.target_shift, or drop agent.start_at_base"
            )
        if out.base_controller != "baseline" and (
            out.target_shift or out.setpoint_gaps_in_obs or out.friction_observer or out.load_estimate_in_obs
        ):
            raise ConfigError(
                f"agent.base_controller {out.base_controller!r}: agent.target_shift, "
                "agent.setpoint_gaps_in_obs, agent.load_estimate_in_obs and agent.friction_observer need "
                "the baseline's set-points; drop them or use base_controller: baseline"
            )
        if out.friction_observer and not out.uses_baseline:
            raise ConfigError(
                "agent.friction_observer changes the baseline's load estimate, and no baseline is used: "
                "set agent.residual, agent.baseline_in_obs, agent.setpoint_gaps_in_obs or agent.target_shift"
            )
        if out.target_shift and (out.baseline_in_obs or out.setpoint_gaps_in_obs):
            raise ConfigError(
                "agent.baseline_in_obs and agent.setpoint_gaps_in_obs cannot be used with "
                "agent.target_shift (the baseline acts after the policy has chosen the shift); drop one"
            )
        return out


def feature_spec(agent: AgentConfig) -> FeatureSpec:
    """What :class:`cepam_gym.policies.Features` reads of an ``agent`` section: every field of
    :class:`~cepam_gym.policies.FeatureSpec`, by name (``start_at_base`` is the trainer's alone)."""
    values = {f.name: getattr(agent, f.name) for f in fields(FeatureSpec)}
    return FeatureSpec(**{**values, "obs_filters_s": tuple(agent.obs_filters_s)})
