"""Measure how runs end under faults (issue 10): time from the fault to a clean stop, whether the
log is readable by the plain ``mcap`` reader, whether it carries ``rths.summary``.

Each fault is injected into a real ``rths run`` (the seed scenario, lockstep, its spawned
``rths specimen``) once the loop is running -- the live ``loop`` stream on zenoh says so:

=================  ===========================================  ==============================
fault              injected                                     "stopped" when
=================  ===========================================  ==============================
sigint|sigterm|    the signal to the coordinator alone          the coordinator has exited
sighup
sigkill            SIGKILL to the coordinator                   its specimen has exited too
specimen-kill      SIGKILL to the specimen process              the coordinator has exited
specimen-hang      SIGSTOP to the specimen process              the coordinator has exited
full-disk          a filler takes a 48 MB tmpfs's free space    the coordinator has exited
                   (``unshare -rm``; skipped where not allowed)
=================  ===========================================  ==============================

Usage::

    python tools/bench_faults.py [--repeat 3] [--faults sigint,specimen-hang,...]

Prints one line per fault: median and worst time [s] from the fault to the stop, exit code, log
readable (y/n; after ``rths recover`` for sigkill), summary present (y/n).  Wall-clock numbers:
say how loaded the machine was (``uptime``, printed first).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from mcap.reader import make_reader

from rths.wire.transport import RunKeys, ZenohEndpoints, loopback_endpoint, open_session

ROOT = Path(__file__).resolve().parent.parent
SEED = ROOT / "scenarios" / "cable_imd_mode3.toml"
FAULTS = (
    "sigint",
    "sigterm",
    "sighup",
    "sigkill",
    "specimen-kill",
    "specimen-hang",
    "full-disk",
)


def _scenario(folder: Path, duration: float) -> Path:
    path = folder / "s.toml"
    text = SEED.read_text().replace("duration = 20.0", f"duration = {duration}", 1)
    path.write_text(text)
    return path


def _pids_of(run_id: str) -> list[int]:
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                cmd = (entry / "cmdline").read_bytes()
                state = (entry / "stat").read_text().split(") ", 1)[1][0]
            except OSError:
                continue
            if run_id.encode() in cmd and state != "Z":
                out.append(int(entry.name))
    return out


def _wait_running(endpoint: str, run_id: str, process: subprocess.Popen, steps: int) -> None:
    seen, count = threading.Event(), [0]

    def on_sample(_: object) -> None:
        count[0] += 1
        if count[0] >= steps:
            seen.set()

    with open_session(ZenohEndpoints(connect=(endpoint,))) as session:
        sub = session.declare_subscriber(RunKeys(run_id).loop, on_sample)
        while not seen.wait(0.2):
            if process.poll() is not None:
                raise RuntimeError(f"run ended before the fault: {process.stderr.read()}")
        sub.undeclare()


def _facts(log: Path) -> tuple[bool, bool]:
    """(readable by the plain reader, rths.summary present)."""
    try:
        with open(log, "rb") as f:
            reader = make_reader(f)
            for _ in reader.iter_messages():
                pass
            names = {m.name for m in reader.iter_metadata()}
        return True, "rths.summary" in names
    except Exception:
        return False, False


def one(fault: str, folder: Path) -> tuple[float, int, bool, bool, str]:
    """Inject ``fault`` once; (seconds to the stop, exit code, readable, summary, stderr)."""
    scenario = _scenario(folder, 60.0)
    log = folder / "run.mcap"
    run_id = f"bench-{fault}-{os.getpid()}-{time.monotonic_ns() % 10**6}"
    endpoint = loopback_endpoint()
    args = [sys.executable, "-m", "rths", "run", str(scenario), "--out", str(log),
            "--listen", endpoint, "--run-id", run_id, "--no-progress"]  # fmt: skip
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _wait_running(endpoint, run_id, process, 4096 if fault == "sigkill" else 500)
    specimen = [p for p in _pids_of(run_id) if p != process.pid]
    t0 = time.monotonic()
    if fault.startswith("sig") and fault != "sigkill":
        process.send_signal(getattr(signal, fault.upper()))
    elif fault == "sigkill":
        process.kill()
    elif fault == "specimen-kill":
        os.kill(specimen[0], signal.SIGKILL)
    elif fault == "specimen-hang":
        os.kill(specimen[0], signal.SIGSTOP)
    _, err = process.communicate()
    elapsed = time.monotonic() - t0
    if fault == "sigkill":
        while _pids_of(run_id):
            time.sleep(0.01)
        elapsed = time.monotonic() - t0  # the orphaned specimen's own exit
        fixed = folder / "run.recovered.mcap"
        subprocess.run([sys.executable, "-m", "rths", "recover", str(log)], check=True,
                       capture_output=True)  # fmt: skip
        readable, summary = _facts(fixed)
    else:
        readable, summary = _facts(log)
    for pid in _pids_of(run_id):  # never leave one behind, even if the fault was mishandled
        os.kill(pid, signal.SIGKILL)
    return elapsed, process.returncode, readable, summary, err.strip()


_FILL = r"""
import os, subprocess, sys, time, warnings
warnings.simplefilter("ignore")
from rths.core.errors import DataError
from rths.log.reader import read_topic
disk, scenario = sys.argv[1:3]
subprocess.run(["mount", "-t", "tmpfs", "-o", "size=48m", "tmpfs", disk], check=True)
log = os.path.join(disk, "run.mcap")
run = subprocess.Popen([sys.executable, "-m", "rths", "run", scenario, "--out", log,
                        "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                       text=True)
seen = 0
while seen < 2000:
    time.sleep(0.05)
    try:
        seen = read_topic(log, "rths/loop")["sequence"].size
    except DataError:
        seen = 0
st = os.statvfs(disk)
t0 = time.monotonic()
with open(os.path.join(disk, "filler"), "wb") as f:
    os.posix_fallocate(f.fileno(), 0, st.f_bavail * st.f_frsize - (1 << 20))
_, err = run.communicate()
elapsed = time.monotonic() - t0
from mcap.reader import make_reader
try:
    with open(log, "rb") as f:
        r = make_reader(f)
        for _ in r.iter_messages():
            pass
        names = {m.name for m in r.iter_metadata()}
    readable, summary = True, "rths.summary" in names
except Exception:
    readable = summary = False
print(f"{elapsed} {run.returncode} {readable} {summary}")
print(err.strip())
"""


def full_disk(folder: Path) -> tuple[float, int, bool, bool, str] | None:
    """The full-disk fault in a private mount namespace; None where that is not allowed."""
    if (
        shutil.which("unshare") is None
        or subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode
    ):
        return None
    disk = folder / "disk"
    disk.mkdir()
    script = folder / "fill.py"
    script.write_text(_FILL)
    scenario = _scenario(folder, 19.5)
    done = subprocess.run(
        ["unshare", "-rm", sys.executable, str(script), str(disk), str(scenario)],
        capture_output=True,
        text=True,
        check=True,
    )
    first, *rest = done.stdout.splitlines()
    elapsed, code, readable, summary = first.split()
    return float(elapsed), int(code), readable == "True", summary == "True", " ".join(rest)


def main() -> None:
    """Run the faults and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--faults", default=",".join(FAULTS))
    args = parser.parse_args()
    print("load:", os.getloadavg())
    print(f"{'fault':<15}{'median s':>9}{'worst s':>9}{'exit':>6}{'log':>5}{'summary':>9}  stderr")
    for fault in args.faults.split(","):
        rows = []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory() as tmp:
                row = full_disk(Path(tmp)) if fault == "full-disk" else one(fault, Path(tmp))
            if row is None:
                break
            rows.append(row)
        if not rows:
            print(f"{fault:<15} skipped (no mount namespace)")
            continue
        times = [r[0] for r in rows]
        codes = sorted({r[1] for r in rows})
        readable = "y" if all(r[2] for r in rows) else "n"
        summary = "y" if all(r[3] for r in rows) else "n"
        err = re.sub(r"\s+", " ", rows[-1][4])[:110]
        print(
            f"{fault:<15}{statistics.median(times):>9.2f}{max(times):>9.2f}"
            f"{'/'.join(map(str, codes)):>6}{readable:>5}{summary:>9}  {err}"
        )


if __name__ == "__main__":
    main()
