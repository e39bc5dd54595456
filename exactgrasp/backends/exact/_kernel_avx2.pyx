# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The exact kernel of ``_kernel.pyx``, compiled for x86-64 CPUs with AVX2 (meson.build builds it
on x86-64 only, with ``-mavx2`` besides the kernels' flags). The same source, the same
operations in the same order, no fused multiply-add: the same bits. Where the compiler may use
SSE4.1 and AVX it selects and rounds without branches or library calls, and the whole kernel
runs about a tenth faster. `exactgrasp.backends.exact.intersector` uses it where the CPU runs
it (`exactgrasp.backends._builds.fastest_build`).
"""

include "_kernel.pyx"
