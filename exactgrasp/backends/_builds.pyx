# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: embedsignature=True
"""Which build of a compiled kernel this CPU runs (Cython).

On x86-64 the voxel estimator's counting kernel and the exact kernel are each compiled twice
(meson.build): for the baseline every x86-64 CPU runs, and again with ``-mavx2`` as
``<name>_avx2``. Both builds come from one source, with the same floating-point operations in
the same order and no fused multiply-add, so they give the same bits; the second is faster
where the CPU runs it. `fastest_build` picks one at import.
"""

import importlib

cdef extern from *:
    """
    #if (defined(__x86_64__) || defined(_M_X64)) && (defined(__GNUC__) || defined(__clang__))
    static int exactgrasp_has_avx2(void) {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2");
    }
    #else
    static int exactgrasp_has_avx2(void) { return 0; }
    #endif
    """
    int exactgrasp_has_avx2() nogil


def cpu_has_avx2():
    """Whether this CPU, and its operating system, run AVX2 code.

    Returns
    -------
    bool
        True on an x86-64 CPU with AVX2 enabled (checked by the compiler's CPU detection,
        which also asks the operating system), False elsewhere.
    """
    return bool(exactgrasp_has_avx2())


def fastest_build(str name):
    """The build of compiled module ``name`` that this CPU runs fastest.

    Parameters
    ----------
    name : str
        The baseline build's full module name, e.g. ``"exactgrasp.backends.exact._kernel"``.

    Returns
    -------
    module
        ``name + "_avx2"`` where the CPU runs AVX2 and the package was built with it (x86-64),
        else ``name``.
    """
    if cpu_has_avx2():
        try:
            return importlib.import_module(name + "_avx2")
        except ImportError:  # built for a CPU family without the AVX2 build
            pass
    return importlib.import_module(name)
