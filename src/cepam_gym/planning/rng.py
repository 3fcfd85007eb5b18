"""NumPy's ``Generator(PCG64)`` inside compiled code, draw for draw.

Each env owns a :class:`numpy.random.Generator` on a PCG64 bit generator (``envs.core`` seeds
them). The reset's random draws (load profiles, segments, target candidates, reference shapes)
run compiled, env by env, so the generator's state is copied into a row of six ``uint64``
(:func:`pack`: the 128-bit LCG state and increment as high and low words, then NumPy's buffered
32-bit half: ``has_uint32``, ``uinteger``), advanced there exactly as NumPy advances it, and
copied back (:func:`unpack`). The draws used:

* :func:`next_double`: ``Generator.random()``; ``uniform(lo, hi)`` is ``lo + (hi - lo) *
  next_double`` in NumPy too (:func:`uniform`);
* :func:`integers`: ``Generator.integers(n)`` for ``1 <= n < 2**32`` (NumPy's Lemire rejection on
  32-bit halves of the stream, the unused half kept for the next such draw).

PCG64 is O'Neill's (2014) XSL-RR output on a 128-bit LCG, as NumPy implements it: step the state,
then output ``rotr64(hi ^ lo, hi >> 58)`` of the new state. The 128-bit arithmetic is one LLVM
``i128`` multiply-add (:func:`_pcg_step`). ``tests/planning/test_reset_kernels.py`` checks every draw
against NumPy on many seeds.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from .._jit import jit_inline

__all__ = ["N_RNG", "Streams", "pack", "unpack", "next_double", "uniform", "integers"]

N_RNG = 6  # state hi, state lo, increment hi, increment lo, has_uint32, uinteger
_S_HI, _S_LO, _I_HI, _I_LO, _HAS32, _U32 = range(N_RNG)
_MASK64 = (1 << 64) - 1
_MULT = 0x2360ED051FC65DA44385DF649FCCF645  # PCG_DEFAULT_MULTIPLIER_128


def pack(rngs) -> np.ndarray:
    """The states of PCG64 generators ``rngs`` (a list, or a :class:`Streams` view) as an
    (n, N_RNG) uint64 array."""
    if isinstance(rngs, _View):
        return rngs.pack()
    out = np.empty((len(rngs), N_RNG), dtype=np.uint64)
    for i, r in enumerate(rngs):
        st = r.bit_generator.state
        if st["bit_generator"] != "PCG64":
            raise TypeError(f"the compiled draws emulate PCG64, got a {st['bit_generator']} generator")
        s, inc = st["state"]["state"], st["state"]["inc"]
        out[i] = (s >> 64, s & _MASK64, inc >> 64, inc & _MASK64, st["has_uint32"], st["uinteger"])
    return out


def unpack(rngs, states: np.ndarray) -> None:
    """Write the states of :func:`pack` (advanced by compiled draws) back into ``rngs``."""
    if isinstance(rngs, _View):
        rngs.unpack(states)
        return
    for r, row in zip(rngs, states.tolist()):
        r.bit_generator.state = {
            "bit_generator": "PCG64",
            "state": {"state": (row[_S_HI] << 64) | row[_S_LO], "inc": (row[_I_HI] << 64) | row[_I_LO]},
            "has_uint32": row[_HAS32],
            "uinteger": row[_U32],
        }


class Streams:
    """The generators of a batch of envs, whose states the compiled draws keep as rows between
    resets: reading and writing a NumPy generator's state costs about 1 us each way, more than a
    planned episode's share of the reset, so a row goes back into its generator only when Python
    code asks for the generator (:meth:`generators`)."""

    def __init__(self, generators):
        self._gens = list(generators)
        self._rows = np.zeros((len(self._gens), N_RNG), dtype=np.uint64)
        self._in_rows = np.zeros(len(self._gens), dtype=bool)  # True: the row is newer

    def __len__(self) -> int:
        return len(self._gens)

    def generators(self, idx=None) -> list:
        """The generators of envs ``idx`` (all if None), brought up to date."""
        idx = np.arange(len(self._gens)) if idx is None else np.asarray(idx)
        stale = idx[self._in_rows[idx]]
        if stale.size:
            unpack([self._gens[i] for i in stale], self._rows[stale])
            self._in_rows[stale] = False
        return [self._gens[i] for i in idx]

    def view(self, idx) -> _View:
        """Envs ``idx`` as :func:`pack` and :func:`unpack` take them (no conversion for rows
        already held)."""
        return _View(self, np.asarray(idx))


class _View:
    def __init__(self, streams: Streams, idx: np.ndarray):
        self.streams, self.idx = streams, idx

    def __len__(self) -> int:
        return len(self.idx)

    def pack(self) -> np.ndarray:
        s = self.streams
        fresh = self.idx[~s._in_rows[self.idx]]
        if fresh.size:
            s._rows[fresh] = pack([s._gens[i] for i in fresh])
            s._in_rows[fresh] = True
        return s._rows[self.idx]

    def unpack(self, states: np.ndarray) -> None:
        self.streams._rows[self.idx] = states
        self.streams._in_rows[self.idx] = True


@intrinsic
def _pcg_step(typingctx, s_hi, s_lo, i_hi, i_lo):
    """One PCG64 step on (state, increment) as 64-bit halves: ``(new hi, new lo, output)`` with
    ``state = state * MULT + inc`` (mod 2**128) and the XSL-RR output of the new state."""
    u64 = types.uint64
    if not all(a == u64 for a in (s_hi, s_lo, i_hi, i_lo)):
        return None
    ret = types.UniTuple(u64, 3)

    def codegen(context, builder, signature, args):
        i64, i128 = ir.IntType(64), ir.IntType(128)
        sh, sl, ih, il = args

        def wide(hi, lo):
            return builder.or_(
                builder.shl(builder.zext(hi, i128), ir.Constant(i128, 64)), builder.zext(lo, i128)
            )

        state = builder.add(builder.mul(wide(sh, sl), ir.Constant(i128, _MULT)), wide(ih, il))
        hi = builder.trunc(builder.lshr(state, ir.Constant(i128, 64)), i64)
        lo = builder.trunc(state, i64)
        rot = builder.lshr(hi, ir.Constant(i64, 58))
        x = builder.xor(hi, lo)
        back = builder.and_(builder.sub(ir.Constant(i64, 64), rot), ir.Constant(i64, 63))
        out = builder.or_(builder.lshr(x, rot), builder.shl(x, back))  # rotate right by rot
        return context.make_tuple(builder, ret, (hi, lo, out))

    return ret(s_hi, s_lo, i_hi, i_lo), codegen


@jit_inline
def next_uint64(s):
    """The next 64-bit output of PCG64 state row ``s`` (advanced in place)."""
    hi, lo, out = _pcg_step(s[_S_HI], s[_S_LO], s[_I_HI], s[_I_LO])
    s[_S_HI] = hi
    s[_S_LO] = lo
    return out


@jit_inline
def next_double(s):
    """``Generator.random()``: the top 53 bits of the next output, in [0, 1)."""
    return np.float64(next_uint64(s) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@jit_inline
def uniform(s, lo, hi):
    """``Generator.uniform(lo, hi)`` (NumPy computes ``lo + (hi - lo) * random()`` too)."""
    return lo + (hi - lo) * next_double(s)


@jit_inline
def _next_uint32(s):
    """NumPy's ``pcg64_next32``: the low half of a fresh output, its high half kept for the next
    call."""
    if s[_HAS32] != 0:
        s[_HAS32] = np.uint64(0)
        return s[_U32]
    out = next_uint64(s)
    s[_HAS32] = np.uint64(1)
    s[_U32] = out >> np.uint64(32)
    return out & np.uint64(0xFFFFFFFF)


@jit_inline
def integers(s, n):
    """``Generator.integers(n)`` for ``1 <= n < 2**32`` (NumPy's ``random_bounded_uint64_fill``
    with Lemire's rejection on 32-bit draws; ``n == 1`` draws nothing)."""
    rng = np.uint64(n - 1)
    if rng == 0:
        return np.int64(0)
    excl = rng + np.uint64(1)
    mask = np.uint64(0xFFFFFFFF)
    m = _next_uint32(s) * excl
    leftover = m & mask
    if leftover < excl:
        threshold = (mask - rng) % excl
        while leftover < threshold:
            m = _next_uint32(s) * excl
            leftover = m & mask
    return np.int64(m >> np.uint64(32))
