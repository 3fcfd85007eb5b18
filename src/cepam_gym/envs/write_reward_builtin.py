"""``python -m cepam_gym.envs.write_reward_builtin``: regenerate ``envs/_reward_builtin.py``, the
package's declared rewards compiled (:func:`cepam_gym.envs.step_source.write_builtin`). A module of
its own because the env package imports :mod:`~cepam_gym.envs.step_source` itself."""

from .step_source import write_builtin

if __name__ == "__main__":
    print(f"wrote {write_builtin().name}")
