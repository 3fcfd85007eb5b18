"""``cepam-gym video``: an episode as a video, the MuJoCo view beside its traces.

    cepam-gym video --controller baseline|zero|random [--env-id ID] [--out FILE.mp4|.gif]
                    [--seconds S] [--fps N] [--seed N] [--run DIR] [--snapshot FRAME.png]

Left: the 3-D view (the rig of :mod:`cepam_gym.mujoco.rig` for the CE-PAM ids, the hinge for
``cepam_gym/CEPAMJoint-v0``). Right: length (or joint angle) and stiffness against their targets
(the whole schedule dashed, the episode so far solid) and both chamber pressures. ``--run DIR``
(or ``--controller DIR``) plays a trained agent's run directory on the rig ids (the ``[train]``
extra). MP4 needs ffmpeg through ``imageio-ffmpeg`` (in the ``[mujoco]`` extra); without it the
video is written as a GIF next to the requested name, with a message.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

from .cli_errors import CommandParser
from .control import controller_names, make_controller
from .errors import InputError
from .versions import RECOMMENDED_ID, short_name

JOINT_ID = "cepam_gym/CEPAMJoint-v0"


class TracePanel:
    """Three stacked plots drawn with matplotlib (Agg) into an RGB array of a fixed size.

    ``rows``: two ``(title, unit, scale, info key, whole target schedule or None, (low, high))``
    (values times ``scale`` are plotted); the chamber pressures are always the third row.
    """

    def __init__(self, width: int, height: int, seconds: float, rows, supply_kpa: float):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.fig = Figure(figsize=(width / 100, height / 100), dpi=100)
        self.canvas = FigureCanvasAgg(self.fig)
        self.axes = self.fig.subplots(3, 1, sharex=True)
        self.fig.subplots_adjust(left=0.15, right=0.97, top=0.95, bottom=0.09, hspace=0.35)
        self.rows = rows
        self.lines = []
        self.t: list[float] = []
        self.data: dict[str, list[float]] = {}
        for ax, (title, unit, scale, key, full, lim) in zip(self.axes, rows):
            ax.set_title(title, fontsize=9, loc="left")
            ax.set_ylabel(unit, fontsize=8)
            ax.tick_params(labelsize=7)
            ax.set_xlim(0, seconds)
            ax.set_ylim(*lim)
            ax.grid(alpha=0.3)
            if full is not None:
                tt = np.arange(len(full)) * seconds / max(len(full), 1)
                ax.plot(tt, np.asarray(full) * scale, "--", color="tab:green", lw=1.0, label="target")
            (line,) = ax.plot([], [], color="black", lw=1.3, label="measured")
            self.lines.append((line, key, scale))
            self.data[key] = []
        ax = self.axes[2]
        ax.set_title("chamber pressures", fontsize=9, loc="left")
        ax.set_ylabel("kPa", fontsize=8)
        ax.set_ylim(0, supply_kpa * 1.1)
        ax.set_xlabel("time [s]", fontsize=8)
        (lc,) = ax.plot([], [], color="tab:red", lw=1.2, label="CPAM Pc")
        (le,) = ax.plot([], [], color="tab:blue", lw=1.2, label="annulus Pe")
        ax.legend(fontsize=7, loc="upper right", framealpha=0.9)
        self.lines += [(lc, "pressure_c", 1e-3), (le, "pressure_e", 1e-3)]
        self.data["pressure_c"], self.data["pressure_e"] = [], []
        self.axes[0].legend(fontsize=7, loc="lower right", framealpha=0.9)
        self.cursor = [ax.axvline(0.0, color="0.6", lw=0.8) for ax in self.axes]
        # blitting: the static parts (axes, targets) are drawn once, each frame only the lines
        self._dynamic = [line for line, _, _ in self.lines] + self.cursor
        for artist in self._dynamic:
            artist.set_animated(True)
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)

    def add(self, t: float, info: dict) -> None:
        self.t.append(t)
        for key in self.data:
            self.data[key].append(float(info[key]))

    def draw(self) -> np.ndarray:
        for line, key, scale in self.lines:
            line.set_data(self.t, np.asarray(self.data[key]) * scale)
        for c in self.cursor:
            c.set_xdata([self.t[-1]] * 2 if self.t else [0.0, 0.0])
        self.canvas.restore_region(self._background)
        for artist in self._dynamic:
            artist.axes.draw_artist(artist)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()


def _rows(env, is_joint: bool, n_steps: int):
    u = env.unwrapped
    if is_joint:
        deg = 180.0 / np.pi
        kt = u.target_stiffness[:n_steps]
        return [
            ("joint angle", "deg", deg, "angle", u.target_angle[:n_steps], (0.0, u.angle_max * deg * 1.05)),
            ("joint stiffness K r^2", "N m/rad", 1.0, "joint_stiffness", kt, (0.0, max(1.0, 1.3 * kt.max()))),
        ]
    from .envs.model import model_of

    model = model_of(env)
    kt = model.target_k[0, :n_steps]
    lo, hi = model.nominal.min_length, model.nominal.max_length
    rows = [("muscle length", "cm", 100.0, "length", model.target_l[0, :n_steps], (lo * 95, hi * 102))]
    if model.track_stiffness:
        rows.append(("stiffness", "N/m", 1.0, "stiffness", kt, (0.0, max(2500.0, 1.3 * kt.max()))))
    else:
        rows.append(("stiffness (free)", "N/m", 1.0, "stiffness", None, (0.0, 2500.0)))
    return rows


def _writer(out: Path, fps: float):
    """``(append(frame), close(), path)``: MP4 through imageio-ffmpeg, else GIF (pillow)."""
    import imageio.v2 as iio

    if out.suffix.lower() != ".gif":
        if importlib.util.find_spec("imageio_ffmpeg") is not None:
            w = iio.get_writer(out, fps=fps, codec="libx264", quality=7, macro_block_size=16)
            return w.append_data, w.close, out
        gif = out.with_suffix(".gif")
        print(
            f"cepam-gym video: no ffmpeg (pip install imageio-ffmpeg, part of the [mujoco] extra); "
            f"writing {gif} instead of {out}",
            file=sys.stderr,
        )
        out = gif
    frames: list[np.ndarray] = []

    def close():
        iio.mimsave(out, frames, duration=1000.0 / fps, loop=0)  # pillow: duration in ms

    return frames.append, close, out


def record(
    env_id: str,
    controller: str,
    out: Path,
    seconds: float,
    fps: float = 25.0,
    seed: int = 0,
    size: int = 480,
    snapshot: Path | None = None,
) -> Path:
    """Run one episode of ``env_id`` under ``controller`` and write the video; returns its path.
    ``snapshot``: also save the last frame as a PNG."""
    import gymnasium as gym

    from .mujoco._mj import require_mujoco

    require_mujoco()
    is_joint = env_id == JOINT_ID
    kwargs = {"episode_seconds": seconds}
    if is_joint:
        kwargs.update(width=size, height=size)
    else:
        kwargs["renderer"] = "mujoco"
    # the loop below stops after `seconds`; the registered time limit must not stop it earlier
    env = gym.make(env_id, render_mode="rgb_array", max_episode_steps=10**9, **kwargs)
    u = env.unwrapped
    dt = u.control_dt  # the rig's and the joint's envs both expose their timing and nominal plant
    n_steps = max(1, round(seconds / dt))
    ctl = make_controller(controller, env)  # the joint's variant on the joint env
    stride = max(1, round(1.0 / (fps * dt)))
    fps_out = 1.0 / (stride * dt)
    obs, info = env.reset(seed=seed)
    ctl.reset()
    supply = u.nominal.supply_pressure / 1e3
    view = env.render()
    h = view.shape[0]
    panel = TracePanel(
        int(round(h * 7 / 6 / 16)) * 16, h, n_steps * dt, _rows(env, is_joint, n_steps), supply
    )
    append, close, path = _writer(out, fps_out)
    try:
        for k in range(n_steps):
            obs, _r, term, trunc, info = env.step(ctl.act(obs, info))
            panel.add((k + 1) * dt, info)
            if k % stride == stride - 1 or term or trunc or k == n_steps - 1:
                frame = np.concatenate([env.render(), panel.draw()], axis=1)
                append(frame)
            if term or trunc:
                print(
                    f"cepam-gym video: episode ended at {(k + 1) * dt:.2f} s "
                    f"({_reason_name(env, info) or 'time limit'})",
                    file=sys.stderr,
                )
                break
    finally:
        close()
        env.close()
    if snapshot is not None:
        import imageio.v3 as iio3

        Path(snapshot).parent.mkdir(parents=True, exist_ok=True)
        iio3.imwrite(snapshot, frame)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = CommandParser(prog="cepam-gym video", description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--controller",
        default="baseline",
        help=f"one of {', '.join(controller_names())}, or a trained agent's run directory (rig ids)",
    )
    ap.add_argument("--run", default=None, help="a trained agent's run directory (same as --controller DIR)")
    ap.add_argument(
        "--env-id", default=None, help=f"default: a run's own env id (--run DIR), else {RECOMMENDED_ID}"
    )
    ap.add_argument(
        "--out", default=None, help="FILE.mp4 or FILE.gif (default runs/video/<id>_<controller>.mp4)"
    )
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--fps", type=float, default=25.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--size", type=int, default=480, help="height of the joint's 3-D view in pixels (the rig's is 480)"
    )
    ap.add_argument("--snapshot", default=None, help="also save the last frame as this PNG")
    args = ap.parse_args(argv)
    controller = args.run or args.controller
    if not args.seconds > 0 or not args.fps > 0:
        ap.error("--seconds and --fps must be > 0")
    if args.env_id is None:
        args.env_id = _run_env_id(Path(controller)) or RECOMMENDED_ID
    if args.out is None:
        stem = short_name(args.env_id) + "_" + Path(controller).name
        out = Path("runs/video") / f"{stem}.mp4"
    else:
        out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        path = record(
            args.env_id,
            controller,
            out,
            args.seconds,
            args.fps,
            args.seed,
            args.size,
            None if args.snapshot is None else Path(args.snapshot),
        )
    except (ImportError, InputError) as e:
        print(f"cepam-gym video: {e}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())


def _run_env_id(run: Path) -> str | None:
    """The env id a trained agent's run directory was trained on (its ``config.yaml``), so that
    ``--run DIR`` plays it on its own env; None for a controller name."""
    path = run / "config.yaml"
    if not path.is_file():
        return None
    import yaml

    try:
        env = (yaml.safe_load(path.read_text()) or {}).get("env") or {}
    except (yaml.YAMLError, AttributeError) as e:
        raise InputError(f"--run {run}: cannot read its config.yaml ({e})") from None
    env_id = env.get("id") if isinstance(env, dict) else None
    return str(env_id) if env_id else None


def _reason_name(env, info) -> str:
    """The termination reason of ``info`` as a name ("" while running): an integer code named by
    the env's ``metadata["termination_reasons"]``, or already a string."""
    reason = info.get("termination_reason")
    names = env.unwrapped.metadata.get("termination_reasons")
    if isinstance(reason, (int, np.integer)) and names is not None:
        return "" if reason == 0 else names[int(reason)]
    return reason or ""
