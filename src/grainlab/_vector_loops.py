"""Building blocks of compiled loops that LLVM turns into vector (SIMD) code, one row per
vector lane: a compiler pipeline that tells LLVM the arrays of a kernel do not overlap
(:class:`DistinctArrays`), the IEEE square root as LLVM's intrinsic (:func:`root`) and a
branch-free choice between two values (:func:`pick`).

Why each is needed (measured on the soft-contact force pass, :mod:`grainlab.engine.
sphere_rows`, with LLVM's vectorizer remarks):

- Numba passes every array as its own pointer but does not promise LLVM that they are
  distinct; a loop that gathers from some arrays and writes others is then left scalar
  ("cannot identify array bounds"). :class:`DistinctArrays` sets Numba's ``noalias`` flag
  (as its parallel loops do once they prove it): the caller must never pass two views of
  one buffer.
- ``math.sqrt`` lowers to the C library's ``sqrt``, which LLVM may keep as a call (it may
  set ``errno``) and never vectorizes; :func:`root` is ``llvm.sqrt``, the same correctly
  rounded result.
- ``a if c else b`` becomes a branch that LLVM does not always turn back into a select;
  :func:`pick` is LLVM's ``select``. Both operands are computed: they must be harmless
  (finite or discarded) whatever the condition.
- Numba wraps negative indices with a select per access, which hides the row stride from
  LLVM's dependence analysis: the vector kernels index with unsigned integers
  (``np.uint64``) and flat (1-D) views of their per-row arrays.

None of this changes a result: LLVM never reorders floating-point arithmetic without
fast-math flags, so a vectorized loop gives the same bits as its scalar form on any x86-64
processor (on one without wide vectors it simply runs scalar).
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import types
from numba.core.compiler import Compiler
from numba.extending import intrinsic


class DistinctArrays(Compiler):
    """Numba's compiler with the ``noalias`` flag: the kernel's array arguments are
    promised to LLVM not to overlap (pass ``pipeline_class=DistinctArrays`` to ``njit``)."""

    def define_pipelines(self):
        self.state.flags.noalias = True
        return super().define_pipelines()


@intrinsic
def root(typingctx, x):
    """sqrt(x) for a float64 x, as LLVM's ``llvm.sqrt`` intrinsic (vectorizable)."""
    if not isinstance(x, types.Float):
        return None

    def codegen(context, builder, signature, args):
        value = context.cast(builder, args[0], signature.args[0], types.float64)
        function = builder.module.declare_intrinsic("llvm.sqrt", [ir.DoubleType()])
        return builder.call(function, [value])

    return types.float64(x), codegen


@intrinsic
def pick(typingctx, condition, if_true, if_false):
    """``if_true`` where ``condition`` holds, else ``if_false`` (float64), as LLVM's
    ``select``: no branch."""
    if not isinstance(condition, types.Boolean):
        return None

    def codegen(context, builder, signature, args):
        a = context.cast(builder, args[1], signature.args[1], types.float64)
        b = context.cast(builder, args[2], signature.args[2], types.float64)
        return builder.select(args[0], a, b)

    return types.float64(condition, if_true, if_false), codegen
