"""Unmanaged array views for the compiled kernels' inner loops.

Numba counts references to every array it passes around: each time an array variable is bound (an argument of an
inlined helper, an element taken from a tuple) it calls ``NRT_incref`` and later ``NRT_decref``, two *atomic*
instructions. In a render kernel that binds its scene tables per sample they were measured at 45 % of the samples
of a profile (``perf``: ``lock incq`` / ``lock decq``), more than Embree itself, and they scale badly over threads
(every thread writes the same counters). :func:`unmanaged` gives a view of an array without a memory-info pointer:
Numba's reference counting then skips it (``NRT_incref`` returns at once on a NULL pointer).

Rule: an unmanaged view does not keep its array alive. Make views only of arrays that outlive them: the arguments of
the function that makes them, or arrays that function allocates and keeps in a variable.
"""
from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic


@intrinsic
def unmanaged(typingctx, arr):
    """A view of the array ``arr`` (same type, data, shape and strides) that Numba does not reference-count."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, args[0])
        dst = context.make_array(sig.return_type)(context, builder)
        dst.meminfo = cgutils.get_null_value(dst.meminfo.type)
        dst.parent = cgutils.get_null_value(dst.parent.type)
        dst.nitems = src.nitems
        dst.itemsize = src.itemsize
        dst.data = src.data
        dst.shape = src.shape
        dst.strides = src.strides
        return dst._getvalue()
    return arr(arr), codegen


@intrinsic
def keep_alive(typingctx, arr):
    """A use of ``arr`` that does nothing: Numba frees a variable's array after its last use, so a function that
    made unmanaged views of its own arrays calls this with each at its end to keep them alive until then."""
    def codegen(context, builder, sig, args):
        return context.get_dummy_value()
    return types.none(arr), codegen


@intrinsic
def pointer(typingctx, arr):
    """The data pointer of the contiguous array ``arr`` (``types.CPointer`` of its dtype): indexed ``ptr[k]`` with
    a flat index (row ``i``, column ``c`` of a C-contiguous 2-D array with ``n`` columns: ``ptr[i * n + c]``).

    Why: Numba reference-counts every binding of an *array* variable, and the inlining of a helper binds its array
    arguments; even on an unmanaged view (:func:`unmanaged`) each binding stays a call to ``NRT_incref`` /
    ``NRT_decref`` (returning at once), hundreds of them in a render kernel's per-sample code, each spilling every
    floating-point register (they are caller-saved) and stopping LLVM's vectoriser. A pointer is a plain value:
    no calls. Same lifetime rule as :func:`unmanaged` (the array must outlive the pointer); no bounds, no negative
    indices."""
    if not (isinstance(arr, types.Array) and arr.layout == "C"):
        return None

    def codegen(context, builder, sig, args):
        return context.make_array(sig.args[0])(context, builder, args[0]).data
    return types.CPointer(arr.dtype)(arr), codegen


@intrinsic
def float32_pointer(typingctx, data):
    """The words of ``data`` (a float64 :func:`pointer`, or a C-contiguous float64 array: its data) read as float32,
    from the same address (``types.CPointer(float32)``): ``ptr[k]`` is the float32 at byte ``4 k``.

    Why: one table can then hold float64 records and, after them, float32 payload (the compiled texture table's
    texels, :mod:`pyrt.textures.compiled`) in one allocation that reaches the kernels as one pointer. Same lifetime
    rule as :func:`pointer`; no bounds."""
    if isinstance(data, types.CPointer) and data.dtype == types.float64:
        def codegen(context, builder, sig, args):
            return builder.bitcast(args[0], context.get_value_type(types.float32).as_pointer())
    elif isinstance(data, types.Array) and data.layout == "C" and data.dtype == types.float64:
        def codegen(context, builder, sig, args):
            ptr = context.make_array(sig.args[0])(context, builder, args[0]).data
            return builder.bitcast(ptr, context.get_value_type(types.float32).as_pointer())
    else:
        return None
    return types.CPointer(types.float32)(data), codegen


@intrinsic
def prefetch(typingctx, ptr, index):
    """Ask the CPU to bring the cache line of ``ptr[index]`` (a :func:`pointer`) into its caches (LLVM's
    ``llvm.prefetch``: a read, kept in all levels); no effect on the program's values, and no fault on any address.

    Why: the environment light's lookups (texels, densities) are memory-bound on maps larger than the L2 cache; a
    packet stage that computes all its lanes' directions first and prefetches their texels, then reads them in a
    second loop, overlaps the lanes' cache misses instead of waiting for each in turn."""
    if not (isinstance(ptr, types.CPointer) and isinstance(index, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        idx = context.cast(builder, args[1], sig.args[1], types.intp)
        addr = builder.bitcast(builder.gep(args[0], [idx]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [addr.type, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0i8")
        builder.call(fn, [addr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()
    return types.none(ptr, index), codegen


#: the LLVM function attribute :func:`wide_vectors` sets (LLVM's own string-attribute syntax)
_PREFER_512 = '"prefer-vector-width"="512"'


@intrinsic
def wide_vectors(typingctx):
    """Let LLVM vectorise the function that calls this with 512-bit vectors where the CPU has them (AVX-512).

    Why: on AVX-512 CPUs LLVM's default tuning prefers 256-bit vectors (``prefer-256-bit``), for fear of the lower
    clock that heavy 512-bit code can bring. Measured on the render kernel's vectorised packet stages (light stage,
    camera rays): 512-bit vectors render ~5-10 % faster, the images bit-identical. The call sets the function
    attribute ``"prefer-vector-width"="512"`` on the function being compiled (not on its callers); on a CPU without
    AVX-512 LLVM uses the widest vectors it has. Call it in the function whose loops it is meant for (a ``_stage``, an
    entry), not in a helper that LLVM inlines (``forceinline=True``): there it marks only the helper's own copy. (llvmlite checks function attributes
    against a list of known names that has no string attributes: the attribute is added to the set directly.)"""
    def codegen(context, builder, sig, args):
        set.add(builder.function.attributes, _PREFER_512)
        return context.get_dummy_value()
    return types.none(), codegen


@intrinsic
def noalias_args(typingctx):
    """Promise LLVM that the pointer arguments of the function that calls this do not alias one another (the LLVM
    ``noalias`` attribute on each): memory written through one is not read or written through another during the
    call.

    Why: a packet stage that gathers from the scene's tables (indices loaded from one table, values from another)
    and writes the packet scratch vectorises only if LLVM knows the stores cannot change the tables; for gathers it
    cannot check that at run time, so without the promise the loop stays scalar. Call it only from a function that
    Numba does not inline (a ``_stage``: its own LLVM function) and whose pointer arguments are distinct buffers, or
    buffers only read. Numba passes a tuple argument as its members, so the pointers in a tuple get it too."""
    def codegen(context, builder, sig, args):
        for a in builder.function.args:
            if isinstance(a.type, ir.PointerType):
                a.add_attribute("noalias")
        return context.get_dummy_value()
    return types.none(), codegen
