"""What a learned policy sees and sends on top of the env's own observation and action: the fields
:class:`~.features.Features` reads, as one frozen record. The training package builds it from its
config's ``agent`` section, which checks the combinations."""

from __future__ import annotations

from dataclasses import dataclass

# the set-point gaps' unit: 100 kPa, the order of the chambers' working range
GAP_UNIT_PA = 1e5


@dataclass(frozen=True)
class FeatureSpec:
    """What the policy sees and sends (all off: the env's observation in, the valve commands out).

    * ``target_shift``: the policy's first actions shift the targets (length by up to
      ``target_shift_length_mm``, on the hinge the joint angle by up to ``target_shift_angle_deg``,
      stiffness by a factor up to ``exp(+-target_shift_stiffness)``,
      low-passed with time constant ``target_shift_filter_s`` [s] if > 0) that the inverse-model
      baseline is given; the baseline's valve commands for them go to the env.
    * ``residual``: the policy's (last) two actions are added:
      ``clip(baseline + residual_scale * a, -1, 1)``.
    * ``baseline_in_obs``: the baseline's action is appended to the env observation.
    * ``setpoint_gaps_in_obs``: the baseline's set-point pressure gaps (model minus measured, per
      chamber, in units of 100 kPa) are appended.
    * ``friction_observer``: the baseline's load estimate includes its friction elements' force.
    * ``base_controller``: the registered controller in the baseline's place (``residual``,
      ``baseline_in_obs``), e.g. ``mpc_friction``.
    * ``obs_filters_s``: low-passed copies of the observation are appended, one per time constant
      [s] (memory over seconds).
    * ``history``: the last ``history`` feature vectors are stacked (oldest first); a new episode
      starts with copies of its first one.
    * ``plant_features``: the plant's parameter columns follow the (stacked) frames, for the actor
      (with ``setpoint_gaps_in_obs``, each frame also holds the set-point gaps of the told plant's
      inverse static model after the nominal model's).
    * ``load_estimate_in_obs``: the adaptive MPC's filtered load estimate [kg] and the nominal
      model's set-point gaps at it are appended (:mod:`.load_estimate`; sensors only).
    * ``privileged_critic``: the privileged columns (:mod:`.privileged`) follow, for the critic
      only.
    """

    residual: bool = False
    residual_scale: float = 0.5
    baseline_in_obs: bool = False
    setpoint_gaps_in_obs: bool = False
    history: int = 1
    target_shift: bool = False
    target_shift_length_mm: float = 5.0
    target_shift_angle_deg: float = 2.0
    target_shift_stiffness: float = 0.4
    target_shift_filter_s: float = 0.0
    obs_filters_s: tuple[float, ...] = ()
    privileged_critic: bool = False
    friction_observer: bool = False
    base_controller: str = "baseline"
    plant_features: bool = False
    load_estimate_in_obs: bool = False

    @property
    def uses_baseline(self) -> bool:
        """Whether the inverse-model baseline (or ``base_controller``) runs beside the policy."""
        return (
            self.residual
            or self.baseline_in_obs
            or self.setpoint_gaps_in_obs
            or self.load_estimate_in_obs
            or self.target_shift
        )
