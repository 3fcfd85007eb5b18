"""Declared records of arrays and scalars, and the two ways they are laid out in memory.

A record is a named tuple declared once as a tuple of :class:`Field` (name, dtype, shape rule).
From the declaration follow:

* :func:`allocate`: the record's arrays for given dimensions (``n`` envs, ``n_steps`` control
  steps, ...), each its own array (the batched env);
* :class:`Slabs`: several records packed into one array per dtype, ``float64``, ``int64`` and
  ``float32`` (the single env: a jitted call with few array arguments dispatches faster), with
  :meth:`Slabs.views` (the records as numpy views, for Python) and :meth:`Slabs.reader` (a numba
  intrinsic that rebuilds a record from the slabs inside a compiled function, as borrowed views
  and loaded scalars).

numba compiles a named tuple of arrays and scalars as a struct: a field is read as ``rec.name``
with no cost beyond the plain arguments it replaces.
"""

from __future__ import annotations

from collections import namedtuple
from typing import NamedTuple

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

_NUMBA = {"f8": types.float64, "i8": types.int64, "f4": types.float32}
SLAB_DTYPES = ("f8", "i8", "f4")  # the slabs' order


class Field(NamedTuple):
    """One field of a record: ``shape`` is ``()`` for a scalar, else a tuple of dimensions, each an
    int or the name of a dimension given at allocation (``"n"``, ``"n_steps"``...)."""

    name: str
    dtype: str  # "f8", "i8" or "f4"
    shape: tuple = ()
    doc: str = ""


def record(name: str, fields: tuple[Field, ...], doc: str, module: str):
    """The named-tuple class of ``fields`` (importable from ``module``, so it pickles), with the
    declaration as its ``FIELDS``."""
    cls = namedtuple(name, [f.name for f in fields], module=module)
    lines = [f"* ``{f.name}`` {f.dtype} {_shape_text(f.shape)}: {f.doc}" for f in fields]
    cls.__doc__ = doc + "\n\nFields:\n\n" + "\n".join(lines)
    cls.FIELDS = fields
    return cls


def _shape_text(shape) -> str:
    return "scalar" if shape == () else "(" + ", ".join(str(d) for d in shape) + ")"


def shape_of(field: Field, dims: dict[str, int]) -> tuple[int, ...]:
    """The field's shape for the named dimensions ``dims``."""
    return tuple(d if isinstance(d, int) else int(dims[d]) for d in field.shape)


def allocate(cls, dims: dict[str, int]):
    """A record of ``cls`` with every array field zeros of its shape (scalars 0)."""
    return cls(
        *(
            np.zeros(shape_of(f, dims), dtype=f.dtype) if f.shape else np.dtype(f.dtype).type(0).item()
            for f in cls.FIELDS
        )
    )


def build(cls, **values):
    """A record of ``cls`` from ``values``, each converted to its field's dtype (Python scalars;
    C-contiguous arrays of the declared shape's rank)."""
    out = []
    for f in cls.FIELDS:
        v = values[f.name]
        if f.shape:
            a = np.ascontiguousarray(v, dtype=f.dtype)
            if a.ndim != len(f.shape):
                raise ValueError(f"{cls.__name__}.{f.name} has {len(f.shape)} dimensions, got {a.shape}")
            out.append(a)
        else:
            out.append(np.dtype(f.dtype).type(v).item())
    return cls(*out)


class _Place(NamedTuple):
    slab: int  # index in SLAB_DTYPES
    offset: int  # first element: offset + steps * n_steps
    steps: int
    shape: tuple  # dims: ints, or "n_steps" / "obs_dim" (the runtime ones)


class Slabs:
    """Where the fields of ``records`` (record classes, with one env: dimension ``n`` is 1) lie in
    one slab per dtype. ``fixed`` names dimensions known when the slabs are declared; the others
    are ``n_steps`` (the float64 slab ends with the fields sized by it, so it is read back from the
    slab's length) and at most one float32 field, which is the whole float32 slab (its own
    array)."""

    def __init__(self, records: tuple, fixed: dict[str, int]):
        self.records, self.fixed = tuple(records), dict(fixed)
        places, fixed_size = {}, [0, 0, 0]
        per_step = [0, 0, 0]
        later = []
        for cls in self.records:
            for f in cls.FIELDS:
                s = SLAB_DTYPES.index(f.dtype)
                shape = tuple(self.fixed.get(d, d) if isinstance(d, str) else d for d in f.shape)
                if s == 2:  # the float32 slab: one field, the whole slab
                    if any(p.slab == 2 for p in places.values()):
                        raise ValueError("a slab layout holds at most one float32 field")
                    places[(cls, f.name)] = _Place(2, 0, 0, shape)
                elif all(isinstance(d, int) for d in shape):
                    places[(cls, f.name)] = _Place(s, fixed_size[s], 0, shape)
                    fixed_size[s] += int(np.prod(shape, dtype=np.int64))
                else:
                    if [d for d in shape if not isinstance(d, int)] != ["n_steps"] or s != 0:
                        raise ValueError(f"{f.name}: only float64 fields may be sized by n_steps")
                    later.append((cls, f.name, shape))
        for cls, name, shape in later:  # after the fixed fields: offset = fixed + k n_steps
            rows = int(np.prod([d for d in shape if isinstance(d, int)], dtype=np.int64))
            places[(cls, name)] = _Place(0, fixed_size[0], per_step[0], shape)
            per_step[0] += rows
        self.places, self.fixed_size, self.per_step = places, fixed_size, per_step[0]

    def allocate(self, n_steps: int, obs_dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The three slabs (zeros) for ``n_steps`` control steps and an ``obs_dim`` observation."""
        F = np.zeros(self.fixed_size[0] + self.per_step * n_steps)
        I = np.zeros(self.fixed_size[1], dtype=np.int64)
        O = np.zeros((1, obs_dim), dtype=np.float32)
        return F, I, O

    def views(self, cls, slabs):
        """The record ``cls`` as numpy views into ``slabs`` (scalars: their current values)."""
        F = slabs[0]
        n_steps = (F.shape[0] - self.fixed_size[0]) // self.per_step if self.per_step else 0
        out = []
        for f in cls.FIELDS:
            p = self.places[(cls, f.name)]
            if p.slab == 2:
                out.append(slabs[2])
                continue
            shape = tuple(n_steps if d == "n_steps" else d for d in p.shape)
            lo = p.offset + p.steps * n_steps
            size = int(np.prod(shape, dtype=np.int64))
            flat = slabs[p.slab][lo : lo + size]
            out.append(flat.reshape(shape) if shape else flat[0].item())
        return cls(*out)

    def write(self, rec, slabs) -> None:
        """Copy record ``rec`` into ``slabs`` (scalars and arrays alike)."""
        F = slabs[0]
        n_steps = (F.shape[0] - self.fixed_size[0]) // self.per_step if self.per_step else 0
        for f, v in zip(rec.FIELDS, rec):
            p = self.places[(type(rec), f.name)]
            if p.slab == 2:
                slabs[2][...] = v
                continue
            lo = p.offset + p.steps * n_steps
            size = int(np.prod([n_steps if d == "n_steps" else d for d in p.shape], dtype=np.int64))
            slabs[p.slab][lo : lo + size] = np.ravel(v)

    def reader(self, cls):
        """A numba intrinsic ``(F, I, O) -> cls``: the record rebuilt inside a compiled function,
        its arrays borrowed views of the slabs (no reference counting, no helper call; valid while
        the slabs are) and its scalars loaded. Offsets are compile-time constants but for the
        fields sized by ``n_steps``, read from ``F``'s length."""
        fields = cls.FIELDS
        places = [self.places[(cls, f.name)] for f in fields]
        member_types = []
        for f, p in zip(fields, places):
            dt = _NUMBA[f.dtype]
            member_types.append(types.Array(dt, len(p.shape), "C") if p.shape else dt)
        ret = types.NamedTuple(member_types, cls)
        fixed_f, per_step = self.fixed_size[0], self.per_step

        @intrinsic
        def read(typingctx, F, I, O):
            ok = (
                isinstance(F, types.Array)
                and F.ndim == 1
                and F.dtype == types.float64
                and isinstance(I, types.Array)
                and I.ndim == 1
                and I.dtype == types.int64
                and isinstance(O, types.Array)
                and O.ndim == 2
                and O.dtype == types.float32
            )
            if not ok:
                return None

            def codegen(context, builder, signature, args):
                intp = context.get_value_type(types.intp)
                arrs = [make_array(signature.args[k])(context, builder, args[k]) for k in range(3)]
                nF = builder.extract_value(arrs[0].shape, 0)
                if per_step:
                    rest = builder.sub(nF, ir.Constant(intp, fixed_f))
                    n_steps = builder.sdiv(rest, ir.Constant(intp, per_step))
                else:
                    n_steps = ir.Constant(intp, 0)
                vals = []
                for p, mt in zip(places, member_types):
                    if p.slab == 2:
                        context.nrt.incref(builder, signature.args[2], args[2])
                        vals.append(args[2])
                        continue
                    src = arrs[p.slab]
                    first = ir.Constant(intp, p.offset)
                    if p.steps:
                        first = builder.add(first, builder.mul(ir.Constant(intp, p.steps), n_steps))
                    ptr = builder.gep(src.data, [first])
                    if not p.shape:
                        vals.append(builder.load(ptr))
                        continue
                    dims = [n_steps if d == "n_steps" else ir.Constant(intp, d) for d in p.shape]
                    size = context.get_abi_sizeof(context.get_data_type(mt.dtype))
                    strides, acc = [], ir.Constant(intp, size)
                    for d in reversed(dims):
                        strides.insert(0, acc)
                        acc = builder.mul(acc, d)
                    out = make_array(mt)(context, builder)
                    populate_array(
                        out,
                        data=ptr,
                        shape=dims,
                        strides=strides,
                        itemsize=ir.Constant(intp, size),
                        meminfo=None,
                        parent=None,
                    )
                    vals.append(out._getvalue())
                return context.make_tuple(builder, ret, vals)

            return ret(F, I, O), codegen

        return read
