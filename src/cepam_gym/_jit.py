"""The one place that decides how the physics is compiled.

``error_model="numpy"`` lets a division by zero give inf/nan instead of raising inside the hot
loop (the plant checks finiteness once per control step). ``cache=True`` keeps the compiled
machine code on disk beside the sources, so a second process starts in well under a second.
"""

from numba import njit

jit = njit(cache=True, error_model="numpy")
# for the small functions of the sub-step loop: inlined at numba IR level, so the loop keeps its
# values in registers instead of passing tuples across calls
jit_inline = njit(cache=True, error_model="numpy", inline="always")
