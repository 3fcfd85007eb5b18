"""Single-file PPO (continuous actions) in the style of CleanRL's ppo_continuous_action.py, on our
native batched env: ``gym.make_vec("cepam_gym/CEPAM-v0", num_envs=N)`` returns a
``CEPAMVectorEnv`` that steps all N plants in one compiled kernel.

    .venv/bin/python examples/cleanrl_ppo.py --total-timesteps 300000

Differences from CleanRL's file, and why:

* Autoreset: our vector env resets a finished env in the SAME step (Gymnasium's
  ``AutoresetMode.SAME_STEP``): the returned observation is already the first of the next episode
  and the last one is in ``infos["final_obs"]``. So ``dones`` cut the GAE recursion, and a
  *truncated* (time-limit, not failed) episode gets ``gamma * V(final_obs)`` added to its last
  reward: the time limit is not part of the task, only of the episode bookkeeping.
* Episode returns are summed here from the raw rewards (the env adds no "episode" info).
* Rewards are scaled by a running std of the discounted return (as CleanRL's NormalizeReward),
  done inline so the raw rewards stay available for logging. Observations are already scaled to
  about unit range by the env, so they are not normalized.
"""

from __future__ import annotations

import argparse
import json
import random
import time

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
import torch.optim as optim
from torch.distributions.normal import Normal


def parse_args(argv=None):
    p = argparse.ArgumentParser(
        description="CleanRL-style PPO on a cepam_gym native vector env",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument("--env-id", default="cepam_gym/CEPAM-v0")
    p.add_argument("--suite", default=None, help="env kwargs of a benchmark suite, e.g. randomized")
    p.add_argument("--env-kwargs", type=json.loads, default={}, help="extra env kwargs as JSON")
    p.add_argument("--max-episode-steps", type=int, default=500, help="steps per episode (500 = 10 s)")
    p.add_argument("--total-timesteps", type=int, default=300_000)
    p.add_argument("--num-envs", type=int, default=32)
    p.add_argument("--num-steps", type=int, default=64, help="steps per env per rollout")
    p.add_argument("--learning-rate", type=float, default=3e-4)
    p.add_argument("--anneal-lr", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--gamma", type=float, default=0.98)
    p.add_argument("--gae-lambda", type=float, default=0.95)
    p.add_argument("--num-minibatches", type=int, default=8)
    p.add_argument("--update-epochs", type=int, default=10)
    p.add_argument("--clip-coef", type=float, default=0.2)
    p.add_argument("--ent-coef", type=float, default=0.0)
    p.add_argument("--vf-coef", type=float, default=0.5)
    p.add_argument("--max-grad-norm", type=float, default=0.5)
    p.add_argument("--target-kl", type=float, default=None)
    p.add_argument("--hidden", type=int, default=64)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--torch-threads", type=int, default=1, help="small MLPs run fastest on one thread")
    p.add_argument("--torch-deterministic", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--log-every", type=int, default=1, help="print every this many updates")
    args = p.parse_args(argv)
    for name in (
        "total_timesteps",
        "num_envs",
        "num_steps",
        "num_minibatches",
        "update_epochs",
        "max_episode_steps",
        "hidden",
        "torch_threads",
        "log_every",
    ):
        if getattr(args, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    args.batch_size = args.num_envs * args.num_steps
    if args.batch_size % args.num_minibatches:
        p.error(f"--num-envs x --num-steps ({args.batch_size}) must be divisible by --num-minibatches")
    args.minibatch_size = args.batch_size // args.num_minibatches
    args.num_iterations = max(1, args.total_timesteps // args.batch_size)
    return args


def layer_init(layer, std=np.sqrt(2), bias_const=0.0):
    torch.nn.init.orthogonal_(layer.weight, std)
    torch.nn.init.constant_(layer.bias, bias_const)
    return layer


class Agent(nn.Module):
    def __init__(self, obs_dim, act_dim, hidden):
        super().__init__()
        self.critic = nn.Sequential(
            layer_init(nn.Linear(obs_dim, hidden)),
            nn.Tanh(),
            layer_init(nn.Linear(hidden, hidden)),
            nn.Tanh(),
            layer_init(nn.Linear(hidden, 1), std=1.0),
        )
        self.actor_mean = nn.Sequential(
            layer_init(nn.Linear(obs_dim, hidden)),
            nn.Tanh(),
            layer_init(nn.Linear(hidden, hidden)),
            nn.Tanh(),
            layer_init(nn.Linear(hidden, act_dim), std=0.01),
        )
        self.actor_logstd = nn.Parameter(torch.full((1, act_dim), -0.5))  # std 0.6 of a [-1, 1] command

    def get_value(self, x):
        return self.critic(x)

    def get_action_and_value(self, x, action=None):
        action_mean = self.actor_mean(x)
        probs = Normal(action_mean, torch.exp(self.actor_logstd.expand_as(action_mean)))
        if action is None:
            action = probs.sample()
        return action, probs.log_prob(action).sum(1), probs.entropy().sum(1), self.critic(x)


class ReturnScaler:
    """Divides rewards by the running std of the discounted return (CleanRL's NormalizeReward)."""

    def __init__(self, num_envs, gamma, eps=1e-8):
        self.ret = np.zeros(num_envs)
        self.gamma, self.eps = gamma, eps
        self.mean, self.var, self.count = 0.0, 1.0, 1e-4

    def __call__(self, reward, done):
        self.ret = self.ret * self.gamma + reward
        b_mean, b_var, n = self.ret.mean(), self.ret.var(), len(self.ret)
        delta, tot = b_mean - self.mean, self.count + n
        self.mean += delta * n / tot
        self.var = (self.var * self.count + b_var * n + delta**2 * self.count * n / tot) / tot
        self.count = tot
        self.ret[done] = 0.0
        return reward / np.sqrt(self.var + self.eps)


def make_env(args):
    import cepam_gym  # noqa: F401  (registers the ids)

    kwargs = {}
    if args.suite is not None:
        from cepam_gym.bench.suites import SUITES

        if args.suite not in SUITES:
            raise SystemExit(f"--suite: unknown suite {args.suite!r}; available: {sorted(SUITES)}")
        kwargs.update(SUITES[args.suite].env_kwargs)
    kwargs.update(args.env_kwargs)
    return gym.make_vec(
        args.env_id,
        num_envs=args.num_envs,
        max_episode_steps=args.max_episode_steps,
        autoreset_mode="same_step",
        **kwargs,
    )


def main(argv=None):
    args = parse_args(argv)
    random.seed(args.seed)
    np.random.seed(args.seed)
    torch.manual_seed(args.seed)
    torch.backends.cudnn.deterministic = args.torch_deterministic
    torch.set_num_threads(args.torch_threads)
    device = torch.device("cpu")

    envs = make_env(args)
    if envs.metadata.get("autoreset_mode") != gym.vector.AutoresetMode.SAME_STEP:
        raise SystemExit(
            f"{type(envs).__name__}: this loop handles same-step autoreset only "
            f"(got {envs.metadata.get('autoreset_mode')})"
        )
    assert isinstance(envs.single_action_space, gym.spaces.Box), "only continuous action space is supported"
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    act_dim = int(np.prod(envs.single_action_space.shape))
    act_low, act_high = envs.single_action_space.low, envs.single_action_space.high

    agent = Agent(obs_dim, act_dim, args.hidden).to(device)
    optimizer = optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)
    scaler = ReturnScaler(args.num_envs, args.gamma)

    obs = torch.zeros((args.num_steps, args.num_envs, obs_dim), device=device)
    actions = torch.zeros((args.num_steps, args.num_envs, act_dim), device=device)
    logprobs = torch.zeros((args.num_steps, args.num_envs), device=device)
    rewards = torch.zeros((args.num_steps, args.num_envs), device=device)
    dones = torch.zeros((args.num_steps, args.num_envs), device=device)
    values = torch.zeros((args.num_steps, args.num_envs), device=device)

    global_step = 0
    start_time = time.time()
    next_obs, _ = envs.reset(seed=args.seed)
    next_obs = torch.as_tensor(next_obs, device=device)
    ep_return = np.zeros(args.num_envs)
    ep_len = np.zeros(args.num_envs, dtype=np.int64)
    finished = []  # (global_step, return, length) of every finished episode
    history = []

    for iteration in range(1, args.num_iterations + 1):
        if args.anneal_lr:
            frac = 1.0 - (iteration - 1.0) / args.num_iterations
            optimizer.param_groups[0]["lr"] = frac * args.learning_rate
        raw_reward_sum = 0.0

        for step in range(args.num_steps):
            global_step += args.num_envs
            obs[step] = next_obs
            with torch.no_grad():
                action, logprob, _, value = agent.get_action_and_value(next_obs)
                values[step] = value.flatten()
            actions[step] = action
            logprobs[step] = logprob

            env_action = np.clip(action.cpu().numpy(), act_low, act_high)
            next_obs_np, reward, terminations, truncations, infos = envs.step(env_action)
            done = np.logical_or(terminations, truncations)
            raw_reward_sum += float(reward.sum())
            scaled = scaler(reward, done)

            # Same-step autoreset: bootstrap truncated episodes from their real last observation.
            if truncations.any():
                final_obs = torch.as_tensor(infos["final_obs"][truncations], device=device)
                with torch.no_grad():
                    scaled[truncations] += args.gamma * agent.get_value(final_obs).flatten().cpu().numpy()

            rewards[step] = torch.as_tensor(scaled, dtype=torch.float32, device=device)
            dones[step] = torch.as_tensor(done, dtype=torch.float32, device=device)
            next_obs = torch.as_tensor(next_obs_np, device=device)

            ep_return += reward
            ep_len += 1
            for i in np.flatnonzero(done):
                finished.append((global_step, float(ep_return[i]), int(ep_len[i])))
                ep_return[i], ep_len[i] = 0.0, 0

        # GAE. dones[t] means the episode ended at step t: the obs at t + 1 belongs to a new one,
        # so nothing is bootstrapped across it (truncation's bootstrap is already in rewards[t]).
        with torch.no_grad():
            next_value = agent.get_value(next_obs).reshape(1, -1)
            advantages = torch.zeros_like(rewards, device=device)
            lastgaelam = 0
            for t in reversed(range(args.num_steps)):
                nextvalues = next_value if t == args.num_steps - 1 else values[t + 1]
                nextnonterminal = 1.0 - dones[t]
                delta = rewards[t] + args.gamma * nextvalues * nextnonterminal - values[t]
                advantages[t] = lastgaelam = (
                    delta + args.gamma * args.gae_lambda * nextnonterminal * lastgaelam
                )
            returns = advantages + values

        b_obs = obs.reshape((-1, obs_dim))
        b_logprobs = logprobs.reshape(-1)
        b_actions = actions.reshape((-1, act_dim))
        b_advantages = advantages.reshape(-1)
        b_returns = returns.reshape(-1)
        b_values = values.reshape(-1)

        b_inds = np.arange(args.batch_size)
        clipfracs = []
        for epoch in range(args.update_epochs):
            np.random.shuffle(b_inds)
            for start in range(0, args.batch_size, args.minibatch_size):
                mb_inds = b_inds[start : start + args.minibatch_size]
                _, newlogprob, entropy, newvalue = agent.get_action_and_value(
                    b_obs[mb_inds], b_actions[mb_inds]
                )
                logratio = newlogprob - b_logprobs[mb_inds]
                ratio = logratio.exp()
                with torch.no_grad():
                    approx_kl = ((ratio - 1) - logratio).mean()
                    clipfracs += [((ratio - 1.0).abs() > args.clip_coef).float().mean().item()]

                mb_advantages = b_advantages[mb_inds]
                mb_advantages = (mb_advantages - mb_advantages.mean()) / (mb_advantages.std() + 1e-8)
                pg_loss1 = -mb_advantages * ratio
                pg_loss2 = -mb_advantages * torch.clamp(ratio, 1 - args.clip_coef, 1 + args.clip_coef)
                pg_loss = torch.max(pg_loss1, pg_loss2).mean()

                newvalue = newvalue.view(-1)
                v_loss_unclipped = (newvalue - b_returns[mb_inds]) ** 2
                v_clipped = b_values[mb_inds] + torch.clamp(
                    newvalue - b_values[mb_inds], -args.clip_coef, args.clip_coef
                )
                v_loss_clipped = (v_clipped - b_returns[mb_inds]) ** 2
                v_loss = 0.5 * torch.max(v_loss_unclipped, v_loss_clipped).mean()

                loss = pg_loss - args.ent_coef * entropy.mean() + v_loss * args.vf_coef
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()
            if args.target_kl is not None and approx_kl > args.target_kl:
                break

        y_pred, y_true = b_values.cpu().numpy(), b_returns.cpu().numpy()
        var_y = np.var(y_true)
        explained_var = np.nan if var_y == 0 else 1 - np.var(y_true - y_pred) / var_y
        sps = int(global_step / (time.time() - start_time))
        reward_per_step = raw_reward_sum / args.batch_size
        recent = [r for s, r, _ in finished if s > global_step - args.batch_size]
        history.append(
            {
                "iteration": iteration,
                "global_step": global_step,
                "reward_per_step": reward_per_step,
                "episodes": len(recent),
                "episodic_return": float(np.mean(recent)) if recent else None,
            }
        )
        if iteration % args.log_every == 0 or iteration == args.num_iterations:
            ep = f"  episodic_return={np.mean(recent):8.2f} ({len(recent)} eps)" if recent else ""
            print(
                f"iter={iteration:4d}  global_step={global_step:8d}  reward/step={reward_per_step:7.3f}{ep}"
                f"  v_loss={v_loss.item():.3f}  approx_kl={approx_kl.item():.4f}"
                f"  clipfrac={np.mean(clipfracs):.3f}  explained_var={explained_var:.2f}  SPS={sps}",
                flush=True,
            )

    envs.close()
    returns_ = [r for _, r, _ in finished]
    k = max(1, min(args.num_envs, len(returns_) // 2))  # one batch of episodes at each end
    summary = {
        "global_step": global_step,
        "seconds": round(time.time() - start_time, 2),
        "steps_per_second": int(global_step / (time.time() - start_time)),
        "reward_per_step_first": history[0]["reward_per_step"],
        "reward_per_step_last": history[-1]["reward_per_step"],
        "episodes": len(returns_),
        "episodic_return_first": float(np.mean(returns_[:k])) if returns_ else None,
        "episodic_return_last": float(np.mean(returns_[-k:])) if returns_ else None,
    }
    print("summary: " + json.dumps(summary), flush=True)
    return summary


if __name__ == "__main__":
    main()
