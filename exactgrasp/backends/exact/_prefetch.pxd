# cython: language_level=3
"""A hint to the CPU that a cache line will be read soon (`prefetch`), for the stages of the
exact kernel that read rows scattered over tables larger than the caches (the hand's faces
along a crossing curve, `_search.trace_pairs`; the co-tree edges' ends,
`_seeds.cotree_seeds`). It loads nothing the program sees: results are the same to the bit
with or without it.

On x86-64 it is the instruction itself (``prefetcht0``, in inline assembly): GCC 12 dropped
``__builtin_prefetch`` from the inlined search loop at ``-O3``. Elsewhere it is the builtin,
or nothing.
"""

cdef extern from *:
    """
    #if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    static inline void eg_prefetch(const void *p) {
        __asm__ volatile("prefetcht0 %0" : : "m"(*(const char *)p));
    }
    #elif defined(__GNUC__)
    static inline void eg_prefetch(const void *p) { __builtin_prefetch(p, 0, 3); }
    #else
    static inline void eg_prefetch(const void *p) { (void)p; }
    #endif
    """
    void prefetch "eg_prefetch"(const void *p) noexcept nogil
