"""The PM QoS CPU wake-up latency request (rths.runtime.cpu_latency): what is written to the
device, that it is held exactly while inside, and that a device that cannot be opened changes
nothing but the summary line.  The device is a file here (the kernel's semantics -- the request
lasts while the file is open -- are Linux's, documented in the module)."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest

from rths.core.errors import ParameterError
from rths.runtime.cpu_latency import CPU_LATENCY_ENV, CpuLatency


def _open_fds() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc (Linux)")
def test_request_is_written_as_int32_and_held_only_inside(tmp_path: Path) -> None:
    device = tmp_path / "cpu_dma_latency"
    device.write_bytes(b"")
    before = _open_fds()
    with CpuLatency(0, device=device) as latency:
        assert latency.held
        assert len(_open_fds() - before) == 1  # the file stays open: the request is held
        assert latency.describe() == "0 us"
    assert _open_fds() == before  # closed on exit: the request is withdrawn
    assert device.read_bytes() == struct.pack("<i", 0)  # what the kernel reads: an s32 [µs]


def test_a_device_that_cannot_be_opened_changes_nothing(tmp_path: Path) -> None:
    with CpuLatency(0, device=tmp_path / "absent") as latency:
        assert not latency.held
    assert latency.describe().startswith("not held (cannot open ")


def test_environment_sets_the_bound_or_disables_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    device = tmp_path / "dev"
    device.write_bytes(b"")
    monkeypatch.setenv(CPU_LATENCY_ENV, "25")
    with CpuLatency(device=device):
        pass
    assert device.read_bytes() == struct.pack("<i", 25)
    monkeypatch.setenv(CPU_LATENCY_ENV, "off")
    with CpuLatency(device=device) as latency:
        assert not latency.held
    assert latency.describe() == "not held (disabled)"


def test_negative_bound_is_refused_naming_the_value() -> None:
    with pytest.raises(ParameterError, match="-3"):
        CpuLatency(-3)
