"""The reference grid's cells (:mod:`agents.reference`): which learner runs which shipped config,
on which ids of the recommended version and which suite, and where each run goes."""

from __future__ import annotations

from pathlib import Path

from cepam_gym import versions

from ..config.files import load_config

# learner -> the shipped config it runs (configs/), all on the recommended id CEPAM-v3
LEARNERS = {
    "PPO": "fast_ppo_v3",
    "SAC": "fast_sac_v3",
    "TD3": "fast_td3_v3",
    "RecurrentPPO": "fast_recurrent_v3",
    "student": "student_mpc_v3",
}
# (learner, mechanism) -> why that cell is not run
SKIPPED = {
    ("student", "hinge"): "its teacher, the adaptive MPC, plans through the rig's kernel only",
}


def recommended_ids() -> list[str]:
    """The ids of the recommended version that have a benchmark suite."""
    version = versions.get(versions.RECOMMENDED_ID).version
    return [i for i in versions.ids(version=version) if versions.get(i).suites]


def suite_of(env_id: str) -> str:
    """The suite a cell trains and is scored on: the id's first headline suite."""
    return versions.get(env_id).suites[0]


def skipped(learner: str, env_id: str) -> str | None:
    return SKIPPED.get((learner, versions.get(env_id).mechanism))


def cell_config(learner: str, env_id: str, minutes: float | None):
    """The config of one cell: ``LEARNERS[learner]`` on ``env_id`` and its suite (the env, the
    periodic evaluation and a student's DAgger suites), its budget ``minutes`` (None: the config's)."""
    import dataclasses

    from ..config.schema import EnvConfig, EvalConfig

    cfg = load_config(LEARNERS[learner])
    suite = suite_of(env_id)
    env = EnvConfig.parse({"id": env_id, "num_envs": cfg.env.num_envs, "suite": suite})
    ev = EvalConfig(cfg.eval.every_steps, cfg.eval.episodes, suite, cfg.eval.seed)
    changes = {"env": env, "eval": ev}
    if cfg.student is not None:  # the same number of DAgger envs per round, on this suite
        changes["student"] = dataclasses.replace(
            cfg.student, suites={suite: sum(cfg.student.suites.values())}
        )
    if minutes is not None:
        changes["time_limit_minutes"] = float(minutes)
    return cfg.replace(**changes)


def cells(learners: list[str], ids: list[str]) -> list[tuple[str, str]]:
    """The (learner, id) pairs of the grid, without the skipped ones."""
    return [(a, i) for i in ids for a in learners if skipped(a, i) is None]


def run_dir(out: Path, learner: str, env_id: str, seed: int) -> Path:
    return out / learner / versions.short_name(env_id) / f"seed{seed}"


def shown_command(argv: list[str]) -> str:
    """The grid's command as the page shows it: without where its files went (``--out``,
    ``--docs``: they change no number) and ``--report-only``."""
    kept, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg in ("--out", "--docs"):
            skip = True
        elif not (arg.startswith(("--out=", "--docs=")) or arg == "--report-only"):
            kept.append(arg)
    return " ".join(["python -m cepam_gym_agents.reference", *kept])
