"""Behaviour cloning (Pomerleau 1991) from a Minari dataset of ``cepam-gym dataset``: the offline-RL
datasets' simplest baseline (docs/datasets.md).

    python -m cepam_gym_agents.bc --dataset cepam/CEPAM-v1/nominal-oracle-v0 --out runs/bc-oracle

An MLP maps the observation to the recorded action (mean squared error, Adam); the episodes are
split into training and validation episodes (whole episodes, so the validation loss is measured
on episodes the network has not seen), and the epoch of the lowest validation loss is kept. The
run directory loads as a controller (``cepam-gym bench --controller runs/bc-oracle``, through
:func:`cepam_gym_agents.policy.load_policy`); unless ``--no-score``, the policy is scored on the
dataset's suite (the benchmark's 20 episodes) and the score, with its headline and normalized
scores from the suite's stored references (as ``cepam-gym bench`` gives them), lands in ``bc.json``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from cepam_gym.cli_errors import CommandParser
from cepam_gym.errors import InputError

from .learners.bc_policy import STD_FLOOR, BCPolicy, make_mlp, save


def load_transitions(dataset) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(observations (T, obs_dim), actions (T, act_dim))`` per episode: each action beside the
    observation it answered (the last observation of an episode has no action)."""
    return [
        (np.asarray(ep.observations[:-1], np.float32), np.asarray(ep.actions, np.float32))
        for ep in dataset.iterate_episodes()
    ]


def split(episodes: list, val_fraction: float) -> tuple[list, list]:
    """Training and validation episodes: the last ``val_fraction`` of them (at least one when
    there are two or more) for validation."""
    n_val = int(round(val_fraction * len(episodes)))
    n_val = min(max(n_val, 1 if len(episodes) > 1 and val_fraction > 0 else 0), len(episodes) - 1)
    return episodes[: len(episodes) - n_val], episodes[len(episodes) - n_val :]


def train_bc(
    episodes: list,
    hidden: list[int],
    epochs: int,
    batch_size: int,
    lr: float,
    seed: int,
    val_fraction: float = 0.1,
) -> tuple[object, np.ndarray, np.ndarray, dict]:
    """``(net, obs_mean, obs_std, log)``: the network of the epoch with the lowest validation loss
    (the last epoch without validation episodes)."""
    import torch

    torch.manual_seed(seed)
    train_eps, val_eps = split(episodes, val_fraction)
    x = np.concatenate([o for o, _ in train_eps])
    y = np.concatenate([a for _, a in train_eps])
    mean, std = x.mean(axis=0), np.maximum(x.std(axis=0), STD_FLOOR)
    xt = torch.from_numpy((x - mean) / std)
    yt = torch.from_numpy(y)
    if val_eps:
        xv = torch.from_numpy((np.concatenate([o for o, _ in val_eps]) - mean) / std)
        yv = torch.from_numpy(np.concatenate([a for _, a in val_eps]))
    net = make_mlp(x.shape[1], y.shape[1], hidden)
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    gen = torch.Generator().manual_seed(seed)
    best, best_state, log = float("inf"), None, {"train_loss": [], "val_loss": []}
    for _ in range(epochs):
        net.train()
        total = 0.0
        for idx in torch.randperm(len(xt), generator=gen).split(batch_size):
            loss = torch.nn.functional.mse_loss(net(xt[idx]), yt[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        log["train_loss"].append(total / len(xt))
        if val_eps:
            net.eval()
            with torch.no_grad():
                val = float(torch.nn.functional.mse_loss(net(xv), yv))
            log["val_loss"].append(val)
        else:
            val = -len(log["train_loss"])  # no validation: the last epoch is kept
        if val < best:
            best, best_state = val, {k: v.clone() for k, v in net.state_dict().items()}
    net.load_state_dict(best_state)
    log.update(
        best_epoch=int(np.argmin(log["val_loss"])) + 1 if val_eps else epochs,
        train_samples=len(xt),
        val_samples=int(len(xv)) if val_eps else 0,
        train_episodes=len(train_eps),
        val_episodes=len(val_eps),
    )
    return net.eval(), mean, std, log


def score_on_suite(policy: BCPolicy, suite_name: str) -> dict:
    """The benchmark's metrics of ``policy`` on the suite's own episodes."""
    from cepam_gym.bench.harness import record
    from cepam_gym.bench.metrics import score_traces
    from cepam_gym.bench.suites import SUITES

    s = SUITES[suite_name]
    tr, track_k = record(lambda venv: policy, s.env_id, s.env_kwargs, s.episodes, s.seed, spec=s.traces)
    return score_traces(tr, track_k, s.traces)


def _positive(kind):
    def parse(text: str):
        value = kind(text)
        if value <= 0:
            raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
        return value

    return parse


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="python -m cepam_gym_agents.bc", description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True, help="Minari dataset id (cepam-gym dataset prints it)")
    ap.add_argument("--out", required=True, help="run directory to write (bc_policy.pt, bc.json)")
    ap.add_argument("--epochs", type=_positive(int), default=100)
    ap.add_argument("--hidden", type=_positive(int), nargs="+", default=[256, 256])
    ap.add_argument("--batch-size", type=_positive(int), default=256)
    ap.add_argument("--lr", type=_positive(float), default=1e-3)
    ap.add_argument("--val-fraction", type=float, default=0.1, help="episodes kept for validation")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=_positive(int), default=1, help="torch threads (a shared machine: 1)")
    ap.add_argument("--no-score", action="store_true", help="skip scoring on the dataset's suite")
    args = ap.parse_args(argv)
    if not 0 <= args.val_fraction < 1:
        raise InputError(f"--val-fraction must be in [0, 1), got {args.val_fraction}")
    try:
        import minari
    except ImportError:
        print("cepam_gym_agents.bc: needs minari: pip install 'cepam-gym[offline]'", file=sys.stderr)
        return 2
    import torch

    torch.set_num_threads(args.threads)
    try:
        dataset = minari.load_dataset(args.dataset)
    except (FileNotFoundError, ValueError) as e:
        raise InputError(f"cannot load dataset {args.dataset!r}: {' '.join(str(e).split())}") from e
    meta = dataset.storage.metadata
    t0 = time.perf_counter()
    net, mean, std, log = train_bc(
        load_transitions(dataset),
        args.hidden,
        args.epochs,
        args.batch_size,
        args.lr,
        args.seed,
        args.val_fraction,
    )
    info = {
        "dataset_id": args.dataset,
        "suite": meta.get("cepam_suite"),
        "env_id": dataset.spec.env_spec.id if dataset.spec.env_spec is not None else None,
        "hidden": args.hidden,
        "epochs": args.epochs,
        "batch_size": args.batch_size,
        "lr": args.lr,
        "seed": args.seed,
        "train_seconds": time.perf_counter() - t0,
        **log,
    }
    out = Path(args.out)
    save(out, net, mean, std, args.hidden, info)
    print(
        f"trained on {log['train_samples']} transitions ({log['train_episodes']} episodes) in "
        f"{info['train_seconds']:.1f} s; best epoch {log['best_epoch']}"
        + (f", validation MSE {min(log['val_loss']):.4g}" if log["val_loss"] else ""),
        flush=True,
    )
    if not args.no_score and info["suite"]:
        metrics = score_on_suite(BCPolicy(net, mean, std), info["suite"])
        from cepam_gym.bench.cli import add_scores

        row = {"suite": info["suite"], "controller": str(out), **metrics}
        add_scores([row])
        info.update({k: row[k] for k in ("score", "failure_rate", "headline", "normalized") if k in row})
        save(out, net, mean, std, args.hidden, info)
        rel = "".join(f", {k} {info[k]:.1f}" for k in ("headline", "normalized") if k in info)
        print(f"benchmark score on {info['suite']}: {metrics['score']:.4g}{rel}", flush=True)
    print(
        f"wrote {out}: score it with cepam-gym bench --controller {out} --suite {info['suite']}", flush=True
    )
    return 0


if __name__ == "__main__":
    from cepam_gym.cli_errors import debug_requested, run_guarded

    debug, rest = debug_requested(sys.argv[1:])
    raise SystemExit(run_guarded("cepam_gym_agents.bc", main, rest, debug))
