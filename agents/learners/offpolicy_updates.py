"""SB3's SAC and TD3 gradient steps, the same arithmetic in fewer Python calls.

Stable-baselines3's ``SAC.train`` spends most of a gradient step of a small network outside the
arithmetic: a ``torch.distributions.Normal`` built (and its arguments validated) twice per step,
the critics reached through their feature extractor and a tuple, a ``.item()`` per loss per
step, the target networks updated one tensor at a time, and the critic's weight gradients
computed on the actor's backward pass only to be zeroed. These functions run the same update on
the same model objects (networks, optimisers, entropy coefficient, replay buffer and its
sampling, the ``_n_updates`` counter and the logged means), so a model trained with them saves,
loads and evaluates as SB3's own; ``tests/agents/test_native_offpolicy.py`` holds them to SB3's
updates on the same data. The differences are rounding: the squashed Gaussian's log-density is
computed from the drawn noise instead of from the action, and the target networks move by
``lerp`` (``target + tau (source - target)``) instead of ``(1 - tau) target + tau source``.
"""

from __future__ import annotations

import math

import torch as th
import torch.nn.functional as F

_LOG_2PI_HALF = 0.5 * math.log(2 * math.pi)
_TANH_EPS = 1e-6  # SB3's TanhBijector epsilon in log(1 - tanh(u)^2 + eps)


def _squashed_sample(actor, obs: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
    """(action, log-density) of SB3's SAC actor at ``obs``: a reparametrised Gaussian draw through
    tanh (``Actor.action_log_prob``), without ``torch.distributions``."""
    latent = actor.latent_pi(actor.features_extractor(obs))
    mean = actor.mu(latent)
    log_std = th.clamp(actor.log_std(latent), -20.0, 2.0)  # SB3's LOG_STD_MIN, LOG_STD_MAX
    eps = th.empty_like(mean).normal_()
    u = mean + log_std.exp() * eps
    a = th.tanh(u)
    log_prob = (-0.5 * eps.square() - log_std - _LOG_2PI_HALF).sum(1) - th.log(
        1 - a.square() + _TANH_EPS
    ).sum(1)
    return a, log_prob


def _q_values(critic, obs: th.Tensor, actions: th.Tensor) -> list[th.Tensor]:
    x = th.cat([critic.features_extractor(obs), actions], dim=1)
    return [q(x) for q in critic.q_networks]


def _frozen(params: list, frozen: bool) -> None:
    for p in params:
        p.requires_grad_(not frozen)


class _Targets:
    """Polyak averaging of (source, target) module pairs, every tensor in one call."""

    def __init__(self, tau: float, pairs):
        self.tau = tau
        self.src = [p.data for s, _ in pairs for p in s.parameters()]
        self.dst = [p.data for _, t in pairs for p in t.parameters()]

    def __call__(self) -> None:
        th._foreach_lerp_(self.dst, self.src, self.tau)


def sac_updates(model, gradient_steps: int, batch_size: int) -> None:
    """``gradient_steps`` of SB3's ``SAC.train`` (module docstring)."""
    assert not model.use_sde, "the native SAC samples plain Gaussian actions"
    model.policy.set_training_mode(True)
    actor, critic, target = model.actor, model.critic, model.critic_target
    optimizers = [actor.optimizer, critic.optimizer]
    learn_alpha = model.ent_coef_optimizer is not None
    if learn_alpha:
        optimizers.append(model.ent_coef_optimizer)
    model._update_learning_rate(optimizers)
    logs = {"actor": [], "critic": [], "ent_coef": [], "ent_coef_loss": []}
    critic_params = list(critic.parameters())
    targets = _Targets(model.tau, [(critic, target)])
    for step in range(gradient_steps):
        data = model.replay_buffer.sample(batch_size, env=model._vec_normalize_env)
        discounts = data.discounts if data.discounts is not None else model.gamma
        actions_pi, log_prob = _squashed_sample(actor, data.observations)
        log_prob = log_prob.reshape(-1, 1)
        if learn_alpha:
            alpha = th.exp(model.log_ent_coef.detach())
            alpha_loss = -(model.log_ent_coef * (log_prob + model.target_entropy).detach()).mean()
            logs["ent_coef_loss"].append(alpha_loss.detach())
            model.ent_coef_optimizer.zero_grad()
            alpha_loss.backward()
            model.ent_coef_optimizer.step()
        else:
            alpha = model.ent_coef_tensor
        logs["ent_coef"].append(alpha)
        with th.no_grad():
            next_a, next_log_prob = _squashed_sample(actor, data.next_observations)
            next_q = th.min(
                th.cat(_q_values(target, data.next_observations, next_a), dim=1), dim=1, keepdim=True
            )[0]
            next_q = next_q - alpha * next_log_prob.reshape(-1, 1)
            y = data.rewards + (1 - data.dones) * discounts * next_q
        critic_loss = 0.5 * sum(F.mse_loss(q, y) for q in _q_values(critic, data.observations, data.actions))
        logs["critic"].append(critic_loss.detach())
        critic.optimizer.zero_grad()
        critic_loss.backward()
        critic.optimizer.step()
        _frozen(critic_params, True)  # the actor's loss needs no critic weight gradients
        q_pi = th.min(th.cat(_q_values(critic, data.observations, actions_pi), dim=1), dim=1, keepdim=True)[0]
        actor_loss = (alpha * log_prob - q_pi).mean()
        logs["actor"].append(actor_loss.detach())
        actor.optimizer.zero_grad()
        actor_loss.backward()
        actor.optimizer.step()
        _frozen(critic_params, False)
        if step % model.target_update_interval == 0:
            targets()
            for s, t in zip(model.batch_norm_stats, model.batch_norm_stats_target, strict=True):
                t.copy_(s)
    model._n_updates += gradient_steps
    _log(model, logs)


def td3_updates(model, gradient_steps: int, batch_size: int) -> None:
    """``gradient_steps`` of SB3's ``TD3.train`` (module docstring)."""
    model.policy.set_training_mode(True)
    actor, critic = model.actor, model.critic
    model._update_learning_rate([actor.optimizer, critic.optimizer])
    logs = {"actor": [], "critic": []}
    critic_params = list(critic.parameters())
    targets = _Targets(model.tau, [(critic, model.critic_target), (actor, model.actor_target)])
    for _ in range(gradient_steps):
        model._n_updates += 1
        data = model.replay_buffer.sample(batch_size, env=model._vec_normalize_env)
        discounts = data.discounts if data.discounts is not None else model.gamma
        with th.no_grad():
            noise = data.actions.clone().normal_(0, model.target_policy_noise)
            noise = noise.clamp(-model.target_noise_clip, model.target_noise_clip)
            next_a = (model.actor_target(data.next_observations) + noise).clamp(-1, 1)
            next_q = th.min(
                th.cat(_q_values(model.critic_target, data.next_observations, next_a), dim=1),
                dim=1,
                keepdim=True,
            )[0]
            y = data.rewards + (1 - data.dones) * discounts * next_q
        critic_loss = sum(F.mse_loss(q, y) for q in _q_values(critic, data.observations, data.actions))
        logs["critic"].append(critic_loss.detach())
        critic.optimizer.zero_grad()
        critic_loss.backward()
        critic.optimizer.step()
        if model._n_updates % model.policy_delay == 0:
            _frozen(critic_params, True)
            x = th.cat([critic.features_extractor(data.observations), actor(data.observations)], dim=1)
            actor_loss = -critic.q_networks[0](x).mean()
            logs["actor"].append(actor_loss.detach())
            actor.optimizer.zero_grad()
            actor_loss.backward()
            actor.optimizer.step()
            _frozen(critic_params, False)
            targets()
            for s, t in zip(
                [*model.critic_batch_norm_stats, *model.actor_batch_norm_stats],
                [*model.critic_batch_norm_stats_target, *model.actor_batch_norm_stats_target],
                strict=True,
            ):
                t.copy_(s)
    _log(model, logs)


def _log(model, logs: dict) -> None:
    """SB3's ``train/*`` records: the means over this call's steps (one synchronisation)."""
    model.logger.record("train/n_updates", model._n_updates, exclude="tensorboard")
    for key, values in logs.items():
        if values:
            model.logger.record(
                f"train/{key}" + ("" if key.startswith("ent") else "_loss"),
                float(th.stack([v.reshape(()) for v in values]).mean()),
            )
