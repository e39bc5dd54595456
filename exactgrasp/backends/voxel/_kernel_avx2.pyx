# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""The counting kernel of ``_kernel.pyx``, compiled for x86-64 CPUs with AVX2 (meson.build builds
it on x86-64 only, with ``-mavx2 -fno-trapping-math`` besides the kernels' flags). The same
source, the same operations in the same order, no fused multiply-add: the same counts.
`exactgrasp.backends.voxel.kernel` uses it where the CPU runs it
(`exactgrasp.backends._builds.fastest_build`).
"""

include "_kernel.pyx"
