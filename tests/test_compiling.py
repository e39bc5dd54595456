"""The kernels' decorators: one compilation per argument type, inner kernels without wrappers."""

from __future__ import annotations

import numba
import numpy as np

from exactgrasp.compiling import inner, kernel


@inner(cache=False, nogil=True)
def _scaled(a, k, flag):
    return a[0] * k if flag else a[1]


@inner(cache=False)
def _pick(pair, k):
    return pair[k]  # a heterogeneous tuple needs a constant index


@kernel(cache=False, nogil=True)
def _total(a):
    token = -1
    s = 0.0
    for _ in range(3):
        s += _scaled(a, 0, True) + _scaled(a, 1, False) + _scaled(a, token, True)
        token += 1
    return s + _pick((1.0, 2), 0) + _pick((1.0, 2), 1)


def test_constants_compile_once_per_type_unless_needed():
    assert _total(np.array([1.0, 2.0])) == 3 * 2.0 + 3.0
    assert len(_scaled.signatures) == 1
    assert [str(t) for t in _scaled.signatures[0][1:]] == ["int64", "bool"]
    assert len(_pick.signatures) == 2


def test_inner_kernels_have_no_python_wrapper_but_python_can_call_them():
    assert _scaled.targetoptions["no_cpython_wrapper"]
    assert "no_cpython_wrapper" not in _total.targetoptions
    assert _scaled(np.array([3.0, 4.0]), 2, True) == 6.0
    assert _scaled(np.array([3.0, 4.0]), 2, False) == 4.0


def test_cache_entries_are_keyed_on_every_kernel_modules_source(monkeypatch):
    # numba checks only a kernel's own file; an edited callee in another file must not load
    # the caller's old machine code.
    from exactgrasp import compiling
    from exactgrasp.backends.exact.pose import pose_volumes

    cache = pose_volumes._cache
    assert isinstance(cache, compiling._KernelCache)
    sig, codegen = (numba.float64,), pose_volumes.targetctx.codegen()
    key = cache._index_key(sig, codegen)
    assert key[-1] == compiling.kernel_sources_digest()
    monkeypatch.setattr(compiling, "kernel_sources_digest", lambda: "edited")
    assert cache._index_key(sig, codegen)[:-1] == key[:-1]
    assert cache._index_key(sig, codegen)[-1] == "edited"
