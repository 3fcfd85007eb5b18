"""Bad input on the v1 ids, tried as a new user would: every case is answered in one line that
names the input and what is expected (issue "House 2", its list of cases), copies and pickles
carry the episode, and stepping before reset is refused."""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

import cepam_gym  # noqa: F401
from cepam_gym.cli_errors import run_guarded
from cepam_gym.envs import CEPAMEnv
from cepam_gym.envs.cepam import CEPAMVectorEnv
from cepam_gym.errors import InputError

RIG, JOINT = "cepam_gym/CEPAM-v1", "cepam_gym/CEPAMJoint-v1"


def _mid_episode(env_id, n=None):
    env = gym.make(env_id) if n is None else gym.make_vec(env_id, num_envs=n)
    env.reset(seed=3)
    a = np.array([0.4, -0.3], np.float32)
    for _ in range(7):
        env.step(a if n is None else np.tile(a, (n, 1)))
    return env


@pytest.mark.parametrize("env_id", [RIG, JOINT])
@pytest.mark.parametrize("n", [None, 3])
@pytest.mark.parametrize("clone", ["deepcopy", "pickle"])
def test_copies_and_pickles_carry_the_episode(env_id, n, clone):
    env = _mid_episode(env_id, n)
    twin = copy.deepcopy(env) if clone == "deepcopy" else pickle.loads(pickle.dumps(env))
    rng = np.random.default_rng(0)
    for _ in range(20):  # noise-free envs: the same actions give the same steps, bit for bit
        a = rng.uniform(-1, 1, (2,) if n is None else (n, 2)).astype(np.float32)
        o1, r1, t1, u1, i1 = env.step(a)
        o2, r2, t2, u2, i2 = twin.step(a)
        np.testing.assert_array_equal(o1, o2)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1, t2)
        assert not np.any(t1)  # a torn copy used to terminate at once with non_finite_state


def test_stepping_before_reset_is_refused():
    with pytest.raises(ResetNeeded, match="reset"):
        CEPAMEnv(task="cepam_v1").step(np.zeros(2))
    with pytest.raises(ResetNeeded, match="reset"):
        CEPAMVectorEnv(num_envs=2, task="cepam_v1").step(np.zeros((2, 2)))
    with pytest.raises(ResetNeeded, match="reset"):
        gym.make(JOINT).unwrapped.step(np.zeros(2))


def test_a_nan_in_one_env_of_a_vector_action_names_the_env_in_one_short_line():
    venv = gym.make_vec(RIG, num_envs=128)
    venv.reset(seed=0)
    a = np.zeros((128, 2))
    a[37, 1] = np.nan
    with pytest.raises(InputError) as e:
        venv.step(a)
    msg = str(e.value)
    assert "[37]" in msg and "NaN" in msg and len(msg) < 200 and "\n" not in msg


@pytest.mark.parametrize(
    "action", ["ab", {"c": 0.1, "e": 0.2}, np.array([0.1 + 0.5j, 0.2]), [0.1 + 1j, 0.0], None]
)
@pytest.mark.parametrize("env_id", [RIG, JOINT])
def test_actions_that_are_not_real_numbers_are_refused_naming_the_action(env_id, action):
    env = gym.make(env_id, disable_env_checker=True)
    env.reset(seed=0)
    with pytest.raises(InputError, match="action must be real numbers"):
        env.unwrapped.step(action)


def test_reset_options_that_are_not_a_dict_are_refused():
    env = gym.make(RIG)
    with pytest.raises(InputError, match="reset options must be a dict"):
        env.reset(seed=0, options=[("target_length", 0.17)])
    with pytest.raises(InputError, match="load_mass"):
        env.reset(seed=0, options={"load_mass": "x"})


@pytest.mark.parametrize("key", ["external_torque", "target_angle", "initial_stiffness"])
def test_joint_reset_options_name_the_key(key):
    env = gym.make(JOINT)
    with pytest.raises(InputError, match=f"reset option {key} must be a number"):
        env.reset(seed=0, options={key: "x"})


@pytest.mark.parametrize("env_id", [RIG, JOINT, "cepam_gym/CEPAM-v2"])
def test_unknown_kwargs_name_the_key_and_list_the_valid_ones(env_id):
    with pytest.raises(InputError) as e:
        gym.make(env_id, episode_secs=5.0)
    msg = str(e.value)
    assert "episode_secs" in msg and "episode_seconds" in msg and "CEPAMBatch" not in msg
    with pytest.raises(InputError, match="episode_secs"):
        gym.make_vec(env_id, num_envs=2, episode_secs=5.0)


@pytest.mark.parametrize("make", ["single", "vector", "mujoco"])
def test_unknown_kwarg_is_pythons_type_error_in_one_line(make, capsys):
    """Clients retry without an optional argument on Python's own TypeError wording (TorchRL's
    GymEnv with ``frameskip``); the command line still prints the error as one line."""
    if make == "mujoco":
        pytest.importorskip("mujoco")

        def build():
            return gym.make("cepam_gym/CEPAMJoint-v0", frameskip=4)
    elif make == "vector":

        def build():
            return gym.make_vec("cepam_gym/CEPAM-v2", num_envs=2, frameskip=4)
    else:

        def build():
            return gym.make("cepam_gym/CEPAM-v2", frameskip=4)

    with pytest.raises(TypeError, match=r"__init__\(\) got an unexpected keyword argument 'frameskip'") as e:
        build()
    assert isinstance(e.value, InputError) and "valid: [" in str(e.value) and "sub_dt" in str(e.value)
    assert run_guarded("cepam-gym x", lambda argv: build(), [], debug=False) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "frameskip" in err
    with pytest.raises(TypeError, match=r"argument 'frameskip' \(and 'skip'\); valid"):
        gym.make("cepam_gym/CEPAM-v2", frameskip=4, skip=1)


def test_only_the_projects_input_error_is_a_one_line_cli_error(capsys):
    def user_mistake(argv):
        raise InputError("--episodes must be >= 1, got 0")

    def bug(argv):
        raise ValueError("an internal invariant broke")

    assert run_guarded("cepam-gym x", user_mistake, [], debug=False) == 2
    assert capsys.readouterr().err.count("\n") == 1
    with pytest.raises(ValueError, match="internal invariant"):  # keeps its traceback
        run_guarded("cepam-gym x", bug, [], debug=False)


def test_video_plays_a_run_on_its_own_env_id(tmp_path):
    from cepam_gym.video import _run_env_id

    (tmp_path / "config.yaml").write_text("env:\n  id: cepam_gym/CEPAMJoint-v1\n  num_envs: 4\n")
    assert _run_env_id(tmp_path) == JOINT
    assert _run_env_id(tmp_path / "missing") is None
    (tmp_path / "config.yaml").write_text("env: [unclosed\n")
    with pytest.raises(InputError, match="config.yaml"):
        _run_env_id(tmp_path)


def _cli(*args, timeout=300):
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-m", "cepam_gym.cli", *args], capture_output=True, text=True, timeout=timeout
    )


@pytest.mark.train
def test_run_with_a_config_typo_fails_before_any_step(tmp_path):
    pytest.importorskip("stable_baselines3")
    r = _cli("run", "--config", "typo", "--out-dir", str(tmp_path))
    assert r.returncode == 2 and "config file not found: typo" in r.stderr
    assert r.stderr.strip().count("\n") == 0 and "Traceback" not in r.stderr
    assert not (tmp_path / "step_response.png").exists()  # nothing ran


@pytest.mark.train
def test_eval_of_a_run_without_a_model_is_one_line_without_the_usage(tmp_path):
    pytest.importorskip("stable_baselines3")
    from pathlib import Path

    shipped = Path(__file__).resolve().parents[2] / "configs" / "quick.yaml"
    (tmp_path / "config.yaml").write_text(shipped.read_text())
    r = _cli("eval", "--run", str(tmp_path))
    assert r.returncode == 2 and "no model in run directory" in r.stderr
    assert "usage:" not in r.stderr and r.stderr.strip().count("\n") == 0
