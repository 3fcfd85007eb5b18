"""``cepam-gym deploy`` and ``cepam-gym rig-emulator`` (docs/deploy.md)."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from ..errors import InputError
from ..versions import RECOMMENDED_ID

DEFAULT_ADDRESS = "127.0.0.1:9870"
DEFAULT_ENV = RECOMMENDED_ID


def _episode(env_id: str, kwargs: dict, seed: int, episode: int, episodes: int):
    """``(single env, its model, target_l, target_k)``: episode ``episode`` of a batch of
    ``episodes`` envs reset with ``seed`` (as the benchmark runs a suite), and a single env of the
    same id for the controller."""
    import gymnasium as gym

    from ..envs.model import model_of

    if not 0 <= episode < episodes:
        raise InputError(f"--episode must lie in [0, {episodes}), got {episode}")
    venv = gym.make_vec(env_id, num_envs=episodes, **kwargs)
    venv.reset(seed=seed)
    vm = model_of(venv)
    tl, tk = vm.target_l[episode].copy(), vm.target_k[episode].copy()
    venv.close()
    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    return env, model_of(env), tl, tk


def build(args):
    """The env, controller, observer and supervisor limits a deploy's arguments ask for."""
    from ..plant.params import PlantParams
    from .observation import RigObserver
    from .supervisor import SafetyLimits

    policy = None
    if args.policy:
        from .onnx_policy import OnnxPolicy

        policy = OnnxPolicy(args.policy)
    kwargs: dict = {}
    env_id = args.env
    seed, episodes = args.seed, args.episode + 1
    if args.suite:
        from ..bench.suites import SUITES

        if args.suite not in SUITES:
            raise InputError(f"unknown suite {args.suite!r}; the suites are {', '.join(SUITES)}")
        s = SUITES[args.suite]
        env_id, kwargs, seed, episodes = s.env_id, dict(s.env_kwargs), s.seed, s.episodes
    elif policy is not None and env_id is None and policy.env_id:
        env_id, kwargs = policy.env_id, dict(policy.env_kwargs or {})
    env_id = env_id or DEFAULT_ENV
    if args.plant:
        kwargs["plant"] = PlantParams.from_yaml(args.plant)
    env, model, tl, tk = _episode(env_id, kwargs, seed, args.episode, episodes)
    if policy is not None:
        policy.check_env(model.obs_dim, model.action_mode)
        controller = policy
    else:
        from ..control import make_controller

        controller = make_controller(args.controller, env)
    limits = SafetyLimits.from_plant(model.nominal)
    if args.limits:
        limits = limits.tightened(args.limits)
    observer = RigObserver(model, tl, tk)
    return env, model, controller, observer, limits


def noise_free_warning(controller) -> str | None:
    """A warning when ``controller`` is an exported policy whose training env had no sensor noise
    (its file's env kwargs): such a policy reads its pressures finer than a rig's sensors give
    them, and on the emulated rig one fell apart (docs/deploy.md, "Train with the rig's sensor
    noise")."""
    if not hasattr(controller, "env_kwargs"):  # a registered controller, not an exported policy
        return None
    kwargs = controller.env_kwargs
    advice = (
        "policies trained on noise-free sensors have failed on the emulated rig. Train with "
        "env.kwargs.sensor_noise about twice your rig's noise (docs/deploy.md)."
    )
    if kwargs is None:
        return f"warning: {controller.path} does not record its training env's sensor noise; {advice}"
    if kwargs.get("sensor_noise"):
        return None
    return (
        f"warning: {controller.path} was trained without sensor noise (its env kwargs have no "
        f"sensor_noise); {advice}"
    )


def deploy_main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="cepam-gym deploy",
        description="run an exported policy or a registered controller on a rig at the env's control "
        "rate, under the safety supervisor; log every step in identify's CSV format",
    )
    who = ap.add_mutually_exclusive_group(required=True)
    who.add_argument("--policy", help="an ONNX file written by cepam-gym export")
    who.add_argument("--controller", help="a registered controller (baseline, mpc, ...)")
    ap.add_argument(
        "--rig", default=DEFAULT_ADDRESS, help=f"the rig's UDP address (default {DEFAULT_ADDRESS})"
    )
    ap.add_argument("--suite", help="play an episode of this benchmark suite (its env, kwargs and seed)")
    ap.add_argument("--episode", type=int, default=0, help="the suite's episode (default 0)")
    ap.add_argument("--env", help=f"env id when no --suite (default: the policy's, else {DEFAULT_ENV})")
    ap.add_argument("--seed", type=int, default=0, help="the episode's seed when no --suite")
    ap.add_argument("--plant", help="the nominal plant YAML the env is built on (e.g. identify's fit)")
    ap.add_argument("--limits", help="a YAML file that tightens the supervisor's limits")
    ap.add_argument("--seconds", type=float, help="stop after this long (default: the whole episode)")
    ap.add_argument("--load-g", type=float, default=0.0, help="the rig's hanging load [g], for the log")
    ap.add_argument(
        "--log", default="runs/deploy/deploy.csv", help="the step log (CSV; a .json summary beside)"
    )
    ap.add_argument(
        "--realtime",
        type=int,
        metavar="PRIORITY",
        help="run the loop under the real-time scheduler (SCHED_FIFO, 1-99; needs root or CAP_SYS_NICE)",
    )
    args = ap.parse_args(argv)
    from .deploy import DeployAborted, run, set_realtime
    from .supervisor import Supervisor
    from .udp import UdpRig, parse_address

    address = parse_address(args.rig)
    if args.realtime is not None:
        print(f"real-time scheduling: {set_realtime(args.realtime)}")
    _env, model, controller, observer, limits = build(args)
    warning = noise_free_warning(controller)
    if warning:
        print(warning, file=sys.stderr)
    n_steps = observer.n_steps
    if args.seconds is not None:
        if not args.seconds > 0:
            raise InputError(f"--seconds must be > 0, got {args.seconds}")
        n_steps = min(n_steps, max(1, int(round(args.seconds / model.control_dt))))
    stop = {"signal": None}

    def _stop(signum, frame):
        stop["signal"] = signum

    old = {sig: signal.signal(sig, _stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    rig = UdpRig(address)
    try:
        print(
            f"deploying on {args.rig} at {1 / model.control_dt:g} Hz for {n_steps} steps; "
            f"limits: {limits.describe()}"
        )
        result = run(
            rig,
            controller,
            observer,
            Supervisor(limits, model.control_dt, model=model),
            args.load_g * 1e-3,
            n_steps=n_steps,
            should_stop=lambda: stop["signal"] is not None,
            log_path=args.log,
        )
    except DeployAborted as e:
        return report_aborted(e, args.log)
    finally:
        rig.close()
        for sig, handler in old.items():
            signal.signal(sig, handler)
    return report(result, args.log)


def report(result, log) -> int:
    """Print a run's summary and where its log is; its exit code (docs/deploy.md, "Exit codes")."""
    from .stop import EXIT_MEANING

    print(result.summary())
    if log:
        print(f"wrote {log} and {Path(log).with_suffix('.json')}")
    if result.exit_code != 0:
        print(f"exit code {result.exit_code}: {EXIT_MEANING[result.exit_code]}", file=sys.stderr)
    return result.exit_code


def report_aborted(e, log) -> int:
    """A loop that raised: its traceback (a bug), then the summary and the stop's outcome."""
    import traceback

    traceback.print_exception(e.__cause__, file=sys.stderr)
    return report(e.result, log)


def _fault(text: str) -> tuple[str, float, float | None, int]:
    """``NAME[.CHANNEL]@SECONDS[:SIZE]`` as ``(name, seconds, size, channel number)``."""
    from .protocol import CHANNELS, FAULTS

    head, sep, rest = text.partition("@")
    name, dot, channel = head.partition(".")
    when, _, size = rest.partition(":")
    try:
        if name not in FAULTS or not sep or (dot and channel not in CHANNELS):
            raise ValueError
        t = float(when)
        s = float(size) if size else None
        if not t >= 0:
            raise ValueError
    except ValueError:
        raise InputError(
            f"--fault must be NAME[.CHANNEL]@SECONDS[:SIZE] with NAME in {', '.join(FAULTS)} and "
            f"CHANNEL in {', '.join(CHANNELS)}; got {text!r}"
        ) from None
    return name, t, s, CHANNELS.index(channel) if dot else 0


def env_setpoint_max(env_id: str, plant: str | None = None) -> float:
    """The gauge pressure [Pa] an action of +1 asks for in pressure mode in the env ``env_id``
    (built on the nominal plant YAML ``plant`` if given): the env's own
    :attr:`~cepam_gym.envs.model.EnvModel.setpoint_max`, so an emulated rig maps the commands as
    the env the controller was made for, whatever plant the rig itself runs."""
    import gymnasium as gym

    from ..envs.model import model_of
    from ..plant.params import PlantParams

    kwargs = {"action_mode": "pressure"}
    if plant:
        kwargs["plant"] = PlantParams.from_yaml(plant)
    env = gym.make(env_id, **kwargs)
    try:
        return float(model_of(env).setpoint_max)
    finally:
        env.close()


def emulator_main(argv: list[str] | None = None) -> int:
    from ..plant import MODES
    from ..plant.params import PlantParams, preset

    ap = argparse.ArgumentParser(
        prog="cepam-gym rig-emulator",
        description="a simulated rig behind the rig protocol (UDP): the plant in real time with latency, "
        "jitter, sensor noise and quantisation, lost packets and injectable faults",
    )
    ap.add_argument("--plant", help="plant parameter YAML (default: --preset)")
    ap.add_argument("--preset", default="balloon_v2")
    ap.add_argument("--port", type=int, default=9870)
    ap.add_argument("--mode", default="valve", choices=sorted(MODES))
    ap.add_argument(
        "--env",
        default=DEFAULT_ENV,
        help="pressure mode: the env whose action map the rig follows (+1 asks for its setpoint_max)",
    )
    ap.add_argument("--env-plant", help="pressure mode: the nominal plant YAML that env is built on")
    ap.add_argument("--load-g", type=float, default=100.0, help="the hanging load [g]")
    ap.add_argument("--rate-hz", type=float, default=500.0, help="plant ticks and sensor packets per second")
    ap.add_argument("--latency-ms", type=float, default=1.0, help="one-way latency of each packet")
    ap.add_argument("--jitter-ms", type=float, default=0.5, help="uniform extra latency per packet")
    ap.add_argument("--noise-kpa", type=float, default=0.2)
    ap.add_argument("--noise-mm", type=float, default=0.03)
    ap.add_argument("--quant-kpa", type=float, default=0.05, help="pressure sensors' resolution")
    ap.add_argument("--quant-mm", type=float, default=0.01, help="length sensor's resolution")
    ap.add_argument("--drop", type=float, default=0.0, help="fraction of packets lost, each direction")
    ap.add_argument(
        "--fault",
        action="append",
        default=[],
        help="NAME[.CHANNEL]@SECONDS[:SIZE]: inject a fault that long after arming (the plant's: "
        "frozen_sensor, supply_drop, leak, stuck_valve; one channel's, CHANNEL one of pressure_c, "
        "pressure_e, length, supply: channel_value (it reads SIZE, SI, e.g. nan), frozen_channel; the "
        "link's: silent, lose_stops, no_watchdog, reboot); repeatable",
    )
    ap.add_argument(
        "--link-fault",
        action="append",
        default=[],
        help="a fault of the link from the start: silent, ignore_arm, lose_stops, no_watchdog; repeatable",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seconds", type=float, help="exit after this long (default: until SIGINT/SIGTERM)")
    ap.add_argument("--events", help="write the events (JSON lines) here instead of stdout")
    ap.add_argument("--realtime", type=int, metavar="PRIORITY", help="SCHED_FIFO priority (see deploy)")
    args = ap.parse_args(argv)
    from .deploy import set_realtime
    from .emulator import EmulatedPlant, RigImperfections, serve

    if args.realtime is not None:
        set_realtime(args.realtime)
    if not 0 <= args.port < 65536:
        raise InputError(f"--port must lie in [0, 65535], got {args.port}")
    if not args.rate_hz >= 50:
        raise InputError(f"--rate-hz must be >= 50, got {args.rate_hz}")
    faults = [_fault(f) for f in args.fault]
    params = PlantParams.from_yaml(args.plant) if args.plant else preset(args.preset)
    imp = RigImperfections(
        latency_s=args.latency_ms * 1e-3,
        jitter_s=args.jitter_ms * 1e-3,
        noise_pressure=args.noise_kpa * 1e3,
        noise_length=args.noise_mm * 1e-3,
        quant_pressure=args.quant_kpa * 1e3,
        quant_length=args.quant_mm * 1e-3,
        drop=args.drop,
    )
    setpoint_max = env_setpoint_max(args.env, args.env_plant) if args.mode == "pressure" else None
    plant = EmulatedPlant(
        params, mode=args.mode, load=args.load_g * 1e-3, rate_hz=args.rate_hz, setpoint_max=setpoint_max
    )
    events = open(args.events, "a") if args.events else None  # noqa: SIM115 (held for the process)
    try:
        return serve(
            plant, args.port, imp, args.seed, faults, args.seconds, events, link_faults=tuple(args.link_fault)
        )
    finally:
        if events is not None:
            events.close()


def excite_main(argv: list[str] | None = None) -> int:
    """``cepam-gym excite``: identify's excitation schedule (:func:`cepam_gym.identify.cli.excite_main`),
    or with ``--rig`` that schedule played on a rig through the deploy loop."""
    from ..identify.cli import excite_loads, excite_parser
    from ..identify.cli import excite_main as schedule_main

    ap = excite_parser()
    ap.add_argument(
        "--rig",
        help="play the schedule on the rig at HOST:PORT through the deploy loop (under the safety "
        "supervisor, at --rate) and write what it measured to --out; --loads-g: the rig's one hanging load",
    )
    ap.add_argument("--env", default=DEFAULT_ENV, help="with --rig: the env whose plant and limits apply")
    ap.add_argument("--limits", help="with --rig: a YAML file that tightens the supervisor's limits")
    ap.add_argument(
        "--plant",
        help="with --rig: the rig's plant YAML (e.g. identify's fit): its limits, and the model-based "
        "leak balance (without it, only the model-free checks run: the first contact with a rig)",
    )
    args = ap.parse_args(argv)
    if args.rig is None:
        return schedule_main(args=args)
    from .deploy import DeployAborted
    from .excitation import excite
    from .supervisor import SafetyLimits
    from .udp import UdpRig, parse_address

    if args.simulate:
        raise InputError("--simulate and --rig exclude each other: the rig measures")
    if args.loads_g is None:
        raise InputError("--rig needs --loads-g: the load hanging on the rig [g], written in the log")
    loads = excite_loads(args.loads_g)
    if len(loads) != 1:
        raise InputError(f"--loads-g: a rig hangs one load during an excitation, got {len(loads)}")
    address = parse_address(args.rig)
    kwargs = {"action_mode": args.mode}
    if args.rate is not None:
        if not 50 <= args.rate <= 2000:
            raise InputError(f"--rate must lie in [50, 2000] Hz, got {args.rate:g}")
        kwargs["control_dt"] = 1.0 / args.rate
    if args.plant:
        from ..plant.params import PlantParams

        kwargs["plant"] = PlantParams.from_yaml(args.plant)
    _env, model, _tl, _tk = _episode(args.env, kwargs, 0, 0, 1)
    limits = SafetyLimits.from_plant(model.nominal)
    if args.limits:
        limits = limits.tightened(args.limits)
    checks = "with the leak balance on --plant" if args.plant else "model-free checks (no --plant)"
    rig = UdpRig(address)
    try:
        print(f"exciting the rig at {args.rig}: {args.seconds:g} s at {1 / model.control_dt:g} Hz, {checks}")
        result = excite(
            rig,
            model,
            args.seconds,
            loads[0] * 1e-3,
            args.out,
            args.seed,
            limits,
            model_based=bool(args.plant),
        )
    except DeployAborted as e:
        return report_aborted(e, args.out)
    finally:
        rig.close()
    code = report(result, args.out)
    if code == 0:
        print(f"{args.out} is the rig's log, for cepam-gym identify --data")
    return code
