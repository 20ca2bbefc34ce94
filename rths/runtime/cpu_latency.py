"""Keep the CPUs out of deep idle states while a real-time or lockstep run lasts (Linux PM QoS).

An idle CPU halts; waking it for the next message costs tens of microseconds on bare metal and
more in a virtual machine, where a halted vCPU is descheduled by the hypervisor.  A synchronous
real-time step wakes six threads in two processes (zenoh's receive threads, the specimen's
serving thread, the loop thread), so that cost is paid six times per step.  Linux's PM QoS
interface lets a process ask for a bound on the CPU wake-up latency: writing a 32-bit integer
[µs] to ``/dev/cpu_dma_latency`` and *keeping the file open* holds the request; closing it (or
the process ending, however it ends) withdraws it.  A bound of 0 keeps idle CPUs polling instead
of halting.  It is what ``cyclictest`` does by default and what the ``latency-performance``
profile of ``tuned`` sets; it costs power (idle CPUs spin), not CPU time of other work.

Measured on the 2-core development VM (``haltpoll`` cpuidle driver), quiet, without and with
the request held (``python tools/bench_wakeup.py``): a pipe round trip between two processes
p50 55 → 8 µs, p99 152 → 31 µs; a zenoh peer-to-peer round trip between two Python processes
p50 246 → 94 µs, p99 444 → 190 µs.

Lockstep runs hold it too: each lockstep step is a round trip between the two processes, so
the same wake-ups bound its speed.  Seed scenario, quiet VM, ``python tools/bench_loop.py
--rates 2048 4096 --clocks lockstep --duration 10 --repeats 2``, with → without
(``RTHS_CPU_LATENCY_US=off``): round trip 230 → 403 µs at 2048 Hz and 271 → 427 µs at 4096 Hz;
whole run 1.24× → 0.86× and 0.66× → 0.46× real time; the results are bit-identical either way.

The request needs write access to the device (root, or a udev rule granting it to a lab group);
without it nothing changes and :attr:`CpuLatency.held` says so, in the run's summary.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

from rths.core.errors import check_nonnegative

__all__ = ["CPU_LATENCY_ENV", "DEVICE", "CpuLatency"]

#: The PM QoS device (Linux).
DEVICE = Path("/dev/cpu_dma_latency")

#: Environment variable: the wake-up latency bound to request [µs] (default 0); ``off`` (or
#: ``none``) leaves the CPUs' idle states alone.
CPU_LATENCY_ENV = "RTHS_CPU_LATENCY_US"


class CpuLatency:
    """Hold a PM QoS CPU wake-up latency request while inside (a context manager).

    Parameters
    ----------
    bound_us
        Latency bound [µs], >= 0; None (default): the environment variable
        :data:`CPU_LATENCY_ENV`, else 0.  ``off`` in the variable disables the request.
    device
        The PM QoS device (tests pass a file).

    Attributes
    ----------
    held : bool
        Whether the request was held inside (the device was opened and written); it stays True
        after the exit, for the summary.
    reason : str
        Why not, when it is not held ("" when it is).
    bound_us : int or None
        The bound requested [µs]; None when disabled.
    """

    def __init__(self, bound_us: int | None = None, device: str | os.PathLike[str] = DEVICE):
        if bound_us is None:
            text = os.environ.get(CPU_LATENCY_ENV, "").strip().lower()
            if text in ("off", "none"):
                self.bound_us: int | None = None
            else:
                try:
                    bound_us = int(text) if text else 0
                except ValueError:
                    bound_us = 0
                self.bound_us = int(check_nonnegative(bound_us, CPU_LATENCY_ENV))
        else:
            self.bound_us = int(check_nonnegative(bound_us, "CPU latency bound [µs]"))
        self.device = Path(device)
        self.held = False
        self.reason = "disabled" if self.bound_us is None else "not entered"
        self._fd: int | None = None

    def __enter__(self) -> CpuLatency:
        if self.bound_us is None:
            return self
        try:
            fd = os.open(self.device, os.O_WRONLY)
        except OSError as exc:
            self.reason = f"cannot open {self.device}: {exc.strerror or exc}"
            return self
        try:
            os.write(fd, struct.pack("<i", self.bound_us))
        except OSError as exc:
            os.close(fd)
            self.reason = f"cannot write {self.device}: {exc.strerror or exc}"
            return self
        self._fd, self.held, self.reason = fd, True, ""
        return self

    def __exit__(self, *exc: object) -> None:
        if self._fd is not None:
            os.close(self._fd)  # withdraws the request
            self._fd = None

    def describe(self) -> str:
        """One line for the run's summary: ``"0 us"`` when held, else why not."""
        if self.held:
            return f"{self.bound_us} us"
        return f"not held ({self.reason})"
