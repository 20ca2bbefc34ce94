"""A run computes with one BLAS thread, and the previous limits come back afterwards.

Oracle: threadpoolctl's own report of the loaded BLAS libraries' thread counts.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg  # noqa: F401  (its own OpenBLAS, loaded as in a run)
from threadpoolctl import threadpool_info

from rths.session.blas import one_blas_thread


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_one_blas_thread_limits_and_restores():
    before = _blas_threads()
    with one_blas_thread():
        assert set(_blas_threads()) <= {1}
        assert np.allclose(np.eye(3) @ np.ones(3), 1.0)
    assert _blas_threads() == before

    @one_blas_thread()
    def inside() -> list[int]:
        return _blas_threads()

    assert set(inside()) <= {1}
    assert _blas_threads() == before
