"""The models a run directory holds and how a session saves and finds them: the final and best
models (each with its VecNormalize statistics), ``checkpoints/`` with its index ``latest.json``
(pruned to the newest ``checkpoint.keep``), the resumable models newest first, and loading the
newest one that loads. :mod:`..policy` finds a run's models through the same names."""

from __future__ import annotations

import json
from pathlib import Path

from cepam_gym.cli_errors import guarded_load

from .provenance import now, write_json

# (model, VecNormalize statistics) by what the model is; each beside the run's config.yaml
SAVED = {
    "final": ("model.zip", "vecnormalize.pkl"),
    "best": ("best_model.zip", "best_vecnormalize.pkl"),
}
# the record that says at which step each saved model was taken, and its key for the step
_STEP_RECORD = {"final": ("summary.json", "steps"), "best": ("best.json", "step")}
INDEX = "checkpoints/latest.json"


def read_index(run: Path) -> dict | None:
    """The checkpoint index of a run (the newest checkpoint's files and step), ``None`` if none."""
    path = Path(run) / INDEX
    if not path.is_file():
        return None
    return guarded_load(path, "checkpoint index", lambda: json.loads(path.read_text()))


def save_model(run: Path, which: str, model, vecnorm) -> None:
    """Save ``model`` (and the normalizer's statistics, if any) as the run's ``which`` model."""
    model_name, norm_name = SAVED[which]
    model.save(str(run / model_name))
    if vecnorm is not None:
        vecnorm.save(str(run / norm_name))


class Checkpoints:
    """``checkpoints/`` of one run directory: periodic saves and the models a resume can start from."""

    def __init__(self, run: Path, keep: int, replay_buffer: bool):
        self.run, self.keep, self.replay_buffer = Path(run), keep, replay_buffer
        self.dir = self.run / "checkpoints"

    def save(self, model, vecnorm, n: int, wall_s: float, interrupted: bool = False) -> Path:
        """Save the model at step ``n`` (with its normalizer statistics and, for off-policy
        algorithms when configured, the replay buffer), point the index at it, prune older ones."""
        model_rel = f"checkpoints/model_{n}.zip"
        model.save(str(self.run / model_rel))
        meta = {
            "steps": int(n),
            "model": model_rel,
            "vecnormalize": None,
            "replay_buffer": None,
            "wall_s": wall_s,
            "interrupted": interrupted,
            "saved": now(),
        }
        if vecnorm is not None:
            meta["vecnormalize"] = f"checkpoints/vecnormalize_{n}.pkl"
            vecnorm.save(str(self.run / meta["vecnormalize"]))
        if self.replay_buffer and hasattr(model, "save_replay_buffer"):
            meta["replay_buffer"] = "checkpoints/replay_buffer.pkl"
            model.save_replay_buffer(str(self.run / meta["replay_buffer"]))
        write_json(self.run / INDEX, meta)
        self._prune()
        return self.run / model_rel

    def _prune(self) -> None:
        steps = sorted(int(p.stem.split("_")[1]) for p in self.dir.glob("model_*.zip"))
        for s in steps[: -self.keep]:
            for p in (self.dir / f"model_{s}.zip", self.dir / f"vecnormalize_{s}.pkl"):
                p.unlink(missing_ok=True)

    def resumable(self) -> list[dict]:
        """Resumable models, newest first (each a checkpoint-index dict with a ``source``): the
        checkpoint, the final model, the best one (a run killed before its first checkpoint)."""
        out = []
        meta = read_index(self.run)
        if meta is not None:
            out.append({**meta, "source": "checkpoint"})
        for which in ("final", "best"):
            model, norm = SAVED[which]
            info, key = _STEP_RECORD[which]
            if (self.run / model).is_file() and (self.run / info).is_file():
                try:
                    steps = int(json.loads((self.run / info).read_text())[key])
                except (ValueError, KeyError, TypeError):
                    continue
                out.append(
                    {
                        "steps": steps,
                        "model": model,
                        "replay_buffer": None,
                        "source": model,
                        "vecnormalize": norm if (self.run / norm).is_file() else None,
                    }
                )
        return sorted(out, key=lambda m: -int(m["steps"]))

    def load_newest(self, candidates: list[dict], raw_env, cfg, algo, say):
        """(env, model, candidate) of the newest candidate that loads; a corrupted one is reported
        through ``say`` and skipped. ``raw_env`` is wrapped in the candidate's normalizer."""
        from .envs import normalize

        errors = []
        for cand in candidates:
            norm = self.run / cand["vecnormalize"] if cand.get("vecnormalize") else None
            model_path = self.run / cand["model"]
            try:
                env = guarded_load(norm, "observation normalizer", normalize, raw_env, cfg, norm)
                model = guarded_load(
                    model_path,
                    f"{cfg.algorithm} model",
                    algo.load,
                    str(model_path),
                    env=env,
                    device="cpu",
                )
            except (ValueError, FileNotFoundError) as e:
                errors.append(e)
                say(f"cepam-gym train: {e}; trying an older model", err=True)
                continue
            if cand is not candidates[0]:
                say(f"resuming from {cand['model']} (step {cand['steps']})", err=True)
            return env, model, cand
        raise errors[0]
