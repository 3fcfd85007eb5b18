"""The native vector env follows Gymnasium's vector conventions: both autoreset modes (equal to
Gymnasium's own SyncVectorEnv of single envs), info masks, integer termination codes, call /
get_attr / set_attr, and Gymnasium's vector wrappers run on it."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import cepam_gym  # noqa: F401

ID = "cepam_gym/CEPAM-v0"
pytestmark = pytest.mark.filterwarnings("ignore:supply_pressure.*above burst_pressure")


def _same_infos(ours: dict, ref: dict, where) -> None:
    for k, v in ref.items():
        if k.startswith("_") or k in ("final_obs", "final_info"):
            continue
        assert k in ours and "_" + k in ours, (where, k)
        m = ref["_" + k]
        np.testing.assert_array_equal(ours["_" + k], m, err_msg=f"{where} mask {k}")
        np.testing.assert_array_equal(np.asarray(ours[k])[m], np.asarray(v)[m], err_msg=f"{where} {k}")


@pytest.mark.parametrize("env_id", [ID, "cepam_gym/CEPAMJoint-v1"])  # the joint runs the same classes
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_equals_gymnasium_sync_vector_env_of_single_envs(mode, env_id):
    n, horizon, seed = 3, 7, 4
    # a burst in one env: terminations as well as truncations
    kw = {"max_episode_steps": horizon, "plant": {"supply_pressure_kpa": 330.0}}
    ours = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode.value, **kw)
    ref = SyncVectorEnv([lambda i=i: gym.make(env_id, stream=i, **kw) for i in range(n)], autoreset_mode=mode)
    assert ours.autoreset_mode == mode and ours.metadata["autoreset_mode"] == mode
    o1, i1 = ours.reset(seed=seed)
    o2, i2 = ref.reset(seed=[seed] * n)
    np.testing.assert_array_equal(o1, o2)
    _same_infos(i1, i2, "reset")
    a = np.tile(np.array([[1.0, -1.0], [1.0, 1.0], [-0.5, 0.2]]), (1, 1))
    saw_term = saw_trunc = False
    for t in range(3 * horizon):
        r1 = ours.step(a)
        r2 = ref.step(a)
        for x, y, name in zip(r1[:4], r2[:4], ("obs", "reward", "terminated", "truncated")):
            np.testing.assert_array_equal(x, y, err_msg=f"step {t} {name}")
        _same_infos(r1[4], r2[4], f"step {t}")
        if mode == AutoresetMode.SAME_STEP and "final_obs" in r2[4]:
            np.testing.assert_array_equal(r1[4]["_final_obs"], r2[4]["_final_obs"])
            done = r2[4]["_final_obs"]
            np.testing.assert_array_equal(r1[4]["final_obs"][done], np.stack(r2[4]["final_obs"][done]))
            _same_infos(r1[4]["final_info"], r2[4]["final_info"], f"step {t} final_info")
        saw_term |= r1[2].any()
        saw_trunc |= r1[3].any()
    assert saw_term and saw_trunc


def test_termination_reason_is_an_integer_code_named_in_metadata():
    venv = gym.make_vec(ID, num_envs=2, plant={"supply_pressure_kpa": 400.0})
    env = gym.make(ID, plant={"supply_pressure_kpa": 400.0})
    names = venv.metadata["termination_reasons"]
    assert names == env.unwrapped.metadata["termination_reasons"] and names[0] == "none"
    venv.reset(seed=0)
    env.reset(seed=0)
    for _ in range(200):
        _, _, term, _, info = venv.step(np.ones((2, 2)))
        _, _, term1, _, info1 = env.step(np.ones(2))
        assert info["termination_reason"].dtype.kind == "i" and isinstance(info1["termination_reason"], int)
        if term.any() and term1:
            break
    assert names[info["termination_reason"][np.flatnonzero(term)[0]]] == "burst"
    assert names[info1["termination_reason"]] == "burst"


def test_call_get_attr_set_attr():
    venv = gym.make_vec(ID, num_envs=3)
    assert venv.get_attr("num_envs") == (3, 3, 3)
    assert venv.call("max_episode_steps") == (500,) * 3
    facts = venv.call("render")  # a method: called once, its result per env
    assert facts == (None, None, None)
    venv.set_attr("max_episode_steps", 4)
    venv.reset(seed=0)
    for _ in range(4):
        *_, trunc, _ = venv.step(np.zeros((3, 2)))
    assert trunc.all()
    venv.set_attr("max_episode_steps", [6, 6, 6])
    assert venv.unwrapped.max_episode_steps == 6
    with pytest.raises(ValueError, match="share one object"):
        venv.set_attr("max_episode_steps", [1, 2, 3])
    with pytest.raises(ValueError, match="2 values for 3 envs"):
        venv.set_attr("max_episode_steps", [1, 2])


def test_autoreset_mode_checked():
    with pytest.raises(ValueError, match="autoreset_mode must be one of"):
        gym.make_vec(ID, num_envs=2, autoreset_mode="disabled")


def test_gymnasium_vector_wrappers_run_on_it():
    from gymnasium.wrappers.vector import ClipAction, NormalizeObservation, RecordEpisodeStatistics

    venv = gym.make_vec(ID, num_envs=4, max_episode_steps=10)
    venv = RecordEpisodeStatistics(NormalizeObservation(ClipAction(venv)))
    obs, _ = venv.reset(seed=0)
    episodes = 0
    for _ in range(25):
        obs, r, term, trunc, info = venv.step(np.full((4, 2), 3.0))  # clipped to 1
        assert np.isfinite(obs).all()
        if "episode" in info:
            episodes += int(info["_episode"].sum())
            assert (info["episode"]["l"][info["_episode"]] == 10).all()
    assert episodes == 8
    # the normalised observations are centred (running mean over the steps)
    assert abs(float(obs.mean())) < 3.0
    assert venv.unwrapped.core.prev_action.max() <= 1.0


def test_sb3_adapter_keeps_terminal_observation_semantics():
    pytest.importorskip("stable_baselines3")
    from cepam_gym.integrations.sb3 import SB3VecEnv, make_sb3_vec_env

    env = make_sb3_vec_env(ID, num_envs=2, seed=0, monitor=False, max_episode_steps=3)
    env.reset()
    for t in range(3):
        obs, rew, dones, infos = env.step(np.zeros((2, 2)))
    assert dones.all()
    for i in range(2):
        assert infos[i]["TimeLimit.truncated"] and "terminal_observation" in infos[i]
        assert not np.array_equal(infos[i]["terminal_observation"], obs[i])
        assert "reward_length" in infos[i] and infos[i]["termination_reason"] == 0
    with pytest.raises(ValueError, match="same_step"):
        SB3VecEnv(gym.make_vec(ID, num_envs=2).unwrapped)


def test_torchrl_batched_gym_env_and_wrapper():
    """TorchRL's batched reader failed on the string termination reason; its GymWrapper reads
    ``autoreset_mode`` from a vector env. (torchrl comes with the [test] extra: no skip.)"""
    from torchrl.envs import GymEnv, GymWrapper

    env = GymEnv("cepam_gym:cepam_gym/CEPAM-v0", num_envs=2)  # subprocesses of single envs
    td = env.rollout(5)
    assert tuple(td.batch_size) == (2, 5)
    env.close()
    # the native batch; TorchRL takes same-step (or disabled) autoreset and reads the attribute
    wrapped = GymWrapper(gym.make_vec(ID, num_envs=4, max_episode_steps=3, autoreset_mode="same_step"))
    td = wrapped.rollout(7, break_when_any_done=False)
    assert tuple(td.batch_size) == (4, 7)
    assert td["next", "done"].any()


_TORCHRL_USER_SCRIPT = """
import cepam_gym  # registers the ids (TorchRL's subprocesses are spawned: they re-import this script)
from torchrl.envs import GymEnv

if __name__ == "__main__":
    for n in (0, 2):
        env = GymEnv("cepam_gym/CEPAM-v2", num_envs=n)
        td = env.rollout(4)
        print("rollout", tuple(td.batch_size), td["next", "observation"].shape[-1])
        env.close()
"""


@pytest.mark.slow  # spawns processes that import cepam_gym
def test_torchrl_gym_env_makes_the_recommended_id_by_name(tmp_path):
    """TorchRL's GymEnv passes ``frameskip`` to ``gym.make`` and retries without it only on
    Python's own "unexpected keyword argument 'frameskip'" TypeError: the recommended id by its
    name, single and batched (TorchRL spawns the batch's processes), run as a user's script."""
    import subprocess
    import sys

    script = tmp_path / "torchrl_cepam.py"
    script.write_text(_TORCHRL_USER_SCRIPT)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    n_obs = gym.make("cepam_gym/CEPAM-v2").observation_space.shape[0]
    rollouts = [line for line in out.stdout.splitlines() if line.startswith("rollout ")]
    assert rollouts == [f"rollout (4,) {n_obs}", f"rollout (2, 4) {n_obs}"]


def test_num_threads_gives_the_same_steps_and_is_checked():
    import numba

    n = 300  # above the parallel kernel's threshold
    outs = []
    for threads in (None, 1, numba.config.NUMBA_NUM_THREADS):
        venv = gym.make_vec(ID, num_envs=n, num_threads=threads)
        venv.reset(seed=2)
        a = np.random.default_rng(0).uniform(-1, 1, (n, 2))
        for _ in range(5):
            obs, r, *_ = venv.step(a)
        outs.append((obs, r))
    for obs, r in outs[1:]:
        np.testing.assert_array_equal(obs, outs[0][0])
        np.testing.assert_array_equal(r, outs[0][1])
    for bad in (0, numba.config.NUMBA_NUM_THREADS + 1, 1.5):
        with pytest.raises(ValueError, match="num_threads must be"):
            gym.make_vec(ID, num_envs=2, num_threads=bad)
