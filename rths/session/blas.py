"""One BLAS thread while a run lasts (private to the session's runners).

A run's matrices are tiny: designing the LQG compensator, discretising the actuator, summarising
the record.  OpenBLAS nevertheless hands such work to its threads, which then spin for the next
call: on a busy 2-core machine that took 5 ms of CPU per compensator design instead of 1.5, and a
fast run with its writer thread lost ~10 % of its CPU to the spinning.  :func:`one_blas_thread`
limits every BLAS library loaded when it is first used to one thread (threadpoolctl), and restores
the previous limits afterwards; a library loaded later is not limited.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

_controller: ThreadpoolController | None = None


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit BLAS to one thread inside the ``with`` block (or a function it decorates).

    The libraries are looked up once per process (a few milliseconds), not at every use.
    """
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    with _controller.limit(limits=1, user_api="blas"):
        yield
