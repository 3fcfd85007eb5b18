"""Pure physics of the CE-PAM: scalar numba kernels (muscle, valve, air, load) and array wrappers.

Import :mod:`cepam_gym.physics.api` for functions that take arrays of any shape.
"""
