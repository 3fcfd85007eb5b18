"""The one place that decides how the physics is compiled.

``error_model="numpy"`` lets a division by zero give inf/nan instead of raising inside the hot
loop (the plant checks finiteness once per control step). ``cache=True`` keeps the compiled
machine code on disk beside the sources, so a second process starts in well under a second.
"""

import hashlib
from pathlib import Path

from llvmlite import ir
from numba import njit, typeof, types
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

_PKG = Path(__file__).parent


_RECORD_FILES = ("records.py", "state.py", "task_params.py")


def _drop_stale_caches() -> None:
    """Numba's on-disk cache is keyed by each function's own source file, not by what it inlined
    from other files. The kernels inline the column layouts and the physics (``physics/*.py``,
    ``plant/*.py``: constants and ``forceinline`` functions) into kernels of other files
    (``plant/kernel.py``, ``envs/step_kernel.py``...): after an edit there, those would load machine
    code built from the old text. The same holds of the declared records (``envs/records.py``,
    ``envs/state.py``, ``envs/task_params.py``: their fields' places are compiled into the single
    env's step). So the text of those two folders and those files is stamped, and every cached
    kernel of the package is dropped when it changes (best effort: a read-only install keeps its
    caches, which were built with its own sources)."""
    try:
        files = [p for folder in ("physics", "plant") for p in sorted((_PKG / folder).glob("*.py"))]
        records = [p for p in (_PKG / "tasks" / f for f in _RECORD_FILES) if p.exists()]
        text = "".join(p.read_text() for p in files + records)
        stamp = hashlib.sha1(text.encode()).hexdigest()
        path = _PKG / "__pycache__" / "numba_layout.stamp"
        if path.exists() and path.read_text() == stamp:
            return
        for f in list(_PKG.rglob("*.nbi")) + list(_PKG.rglob("*.nbc")):
            f.unlink(missing_ok=True)
        path.parent.mkdir(exist_ok=True)
        path.write_text(stamp)
    except OSError:
        pass


_drop_stale_caches()
jit = njit(cache=True, error_model="numpy")
# for the functions of the sub-step loop: marked ``alwaysinline`` for LLVM, so the loop is one body
# that keeps its values in registers and that LLVM can vectorise across plants. (Numba's own
# ``inline="always"``, which copies numba IR, does the same but multiplies compile times.)
jit_inline = njit(cache=True, error_model="numpy", forceinline=True)


def bound(dispatcher, args):
    """The compiled entry point of ``dispatcher`` for the types of ``args`` (compiled or loaded from
    the cache now): called with arguments of exactly those types, it skips numba's type dispatch,
    which takes microseconds for a named tuple of arrays (the env state) where it takes well under
    one for plain arrays."""
    return dispatcher.compile(tuple(typeof(a) for a in args))


@intrinsic
def _llvm_sqrt(typingctx, x):
    """``llvm.sqrt.f64``: the correctly rounded square root (the same bits as ``math.sqrt``) without
    the libm call ``math.sqrt`` compiles to, which may set ``errno`` and so keeps LLVM from
    vectorising a loop across plants. NaN for a negative argument, like ``math.sqrt`` with
    ``error_model="numpy"``."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        fn = builder.module.declare_intrinsic("llvm.sqrt", [ir.DoubleType()])
        return builder.call(fn, args)

    return types.float64(types.float64), codegen


@jit_inline
def sqrt(x):
    """Square root of a float in the compiled kernels (see :func:`_llvm_sqrt`)."""
    return _llvm_sqrt(float(x))


@jit_inline
def fmax(a, b):
    """``max(a, b)`` of floats, exactly as Python's and numba's (``b if b > a else a``), but inlined
    into the caller: numba compiles the builtin to a call that LLVM inlines too late for the loop
    vectoriser to see through."""
    return b if b > a else a


@jit_inline
def fmin(a, b):
    """``min(a, b)`` of floats, exactly as Python's and numba's (``b if b < a else a``); see
    :func:`fmax`."""
    return b if b < a else a


@intrinsic
def strided_tuple(typingctx, arr, start, n, stride):
    """``(arr[start], arr[start + stride], ..., arr[start + (n-1) stride])`` as a tuple, for a 1-D
    float64 array and literal ints ``n`` and ``stride``: one plain load per element, no array view
    (a view inside a loop is reference-counted, which keeps LLVM from vectorising the loop). The
    plant uses it to hand one plant's column of a structure-of-arrays block to the physics
    functions, which index it like a parameter row (``p[ix.BC]``)."""
    if not (
        isinstance(arr, types.Array)
        and arr.ndim == 1
        and arr.dtype == types.float64
        and isinstance(start, types.Integer)
        and isinstance(n, types.IntegerLiteral)
        and isinstance(stride, types.IntegerLiteral)
    ):
        return None
    count, step = n.literal_value, stride.literal_value
    ret = types.UniTuple(types.float64, count)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        base = builder.gep(ary.data, [args[1]])
        vals = [
            builder.load(builder.gep(base, [ir.Constant(ir.IntType(64), k * step)])) for k in range(count)
        ]
        return context.make_tuple(builder, ret, vals)

    return ret(arr, start, n, stride), codegen


def _borrowed(ndim: int):
    """An intrinsic ``(arr, start, n)`` -> ``arr[start:start + n]`` of a 1-D C-contiguous array as a
    1-D array (``ndim`` 1) or a (1, n) array (``ndim`` 2), without a memory-info pointer: the view
    is borrowed, so passing it on costs no reference counting (an atomic increment and decrement
    per call it crosses) and making it calls no helper (``reshape`` calls one). Only for views that
    live inside the call that made them, while ``arr`` is alive."""

    @intrinsic
    def view(typingctx, arr, start, n):
        if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"):
            return None
        ret = arr.copy(ndim=ndim, layout="C")

        def codegen(context, builder, signature, args):
            src = make_array(signature.args[0])(context, builder, args[0])
            count = context.cast(builder, args[2], signature.args[2], types.intp)
            first = context.cast(builder, args[1], signature.args[1], types.intp)
            size = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(arr.dtype)))
            shape = [count] if ndim == 1 else [context.get_constant(types.intp, 1), count]
            strides = [size] if ndim == 1 else [builder.mul(count, size), size]
            out = make_array(ret)(context, builder)
            populate_array(
                out,
                data=builder.gep(src.data, [first]),
                shape=shape,
                strides=strides,
                itemsize=size,
                meminfo=None,
                parent=None,
            )
            return out._getvalue()

        return ret(arr, start, n), codegen

    return view


vec_view = _borrowed(1)
row_view = _borrowed(2)


@intrinsic
def row_of(typingctx, arr, i):
    """``arr[i]`` of a 2-D C-contiguous array as a borrowed 1-D view (see :func:`_borrowed`): the
    step kernels hand each env's rows to the physics and the task without reference counting."""
    if not (isinstance(arr, types.Array) and arr.ndim == 2 and arr.layout == "C"):
        return None
    ret = arr.copy(ndim=1, layout="C")

    def codegen(context, builder, signature, args):
        src = make_array(signature.args[0])(context, builder, args[0])
        row = context.cast(builder, args[1], signature.args[1], types.intp)
        cols = builder.extract_value(src.shape, 1)
        size = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(arr.dtype)))
        out = make_array(ret)(context, builder)
        populate_array(
            out,
            data=builder.gep(src.data, [builder.mul(row, cols)]),
            shape=[cols],
            strides=[size],
            itemsize=size,
            meminfo=None,
            parent=None,
        )
        return out._getvalue()

    return ret(arr, i), codegen
