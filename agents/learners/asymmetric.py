"""An asymmetric actor-critic policy for PPO: the critic sees the whole input, the actor only the
observation columns (Pinto et al. 2018).

The training env appends the privileged columns (:mod:`cepam_gym.policies.privileged`) after the agent's
features. SB3's ``ActorCriticPolicy`` builds one MLP extractor for both heads on inputs of one
width, so the actor is given the same width with the privileged columns replaced by zeros
(``torch.where``, not a product: a NaN there cannot leak through ``0 * NaN``). A deployed policy
fills those columns with NaN (:class:`agents.policy.AgentPolicy`): if anything of them reached the
actor, its actions would be NaN and the env would refuse them, loudly.
"""

from __future__ import annotations

import torch
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor


class ActorColumns(BaseFeaturesExtractor):
    """The first ``actor_dim`` input columns as they are, the rest zeros (same width)."""

    def __init__(self, observation_space, actor_dim: int):
        super().__init__(observation_space, int(observation_space.shape[0]))
        keep = torch.zeros(int(observation_space.shape[0]), dtype=torch.bool)
        keep[: int(actor_dim)] = True
        self.register_buffer("keep", keep, persistent=False)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.where(self.keep, obs, torch.zeros_like(obs))


class AsymmetricActorCriticPolicy(ActorCriticPolicy):
    """``ActorCriticPolicy`` with separate extractors: the actor's masks the privileged columns."""

    def __init__(self, observation_space, action_space, lr_schedule, actor_dim: int, **kwargs):
        if not 0 < int(actor_dim) < observation_space.shape[0]:
            raise ValueError(f"actor_dim must lie in (0, {observation_space.shape[0]}), got {actor_dim!r}")
        self.actor_dim = int(actor_dim)
        kwargs["share_features_extractor"] = False
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)
        # the extractors hold no parameters, so swapping the actor's after the optimizer was
        # built changes nothing it trains
        self.pi_features_extractor = ActorColumns(observation_space, self.actor_dim)
        self.features_extractor = self.pi_features_extractor

    def _get_constructor_parameters(self) -> dict:
        data = super()._get_constructor_parameters()
        data["actor_dim"] = self.actor_dim
        return data
