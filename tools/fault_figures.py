"""Fault figures of issue 10 in one table: what happens to the actuator and to the log when a
process of a run is signalled, killed, paused or attacked, or its disk fills up.

Faults (seed scenario, ``realtime`` clock by default, coordinator and specimen as separate processes
on this machine, the specimen started here so its pid is known):

* ``sigint`` / ``sigterm`` / ``sighup``  the signal to the coordinator alone;
* ``coordinator-sigkill``    SIGKILL of the coordinator (the specimen ramps down by itself; the
                             log's writer process finishes the file, ``rths recover`` adds the
                             run summary the coordinator could not write; "exited" is when
                             the coordinator's stderr closes, which the writer holds until it
                             has finished the file);
* ``specimen-sigkill``       SIGKILL of the specimen process;
* ``specimen-pause-300ms``   SIGSTOP of the specimen, SIGCONT 0.3 s later;
* ``specimen-gc-106ms``      a 106 ms pause of the specimen (the full collection measured before
                             the loops were made immune to their collector), as SIGSTOP/SIGCONT;
* ``specimen-sigstop``       SIGSTOP of the specimen, resumed only after the coordinator ended;
* ``coordinator-pause-1s``   SIGSTOP of the coordinator for 1 s (the specimen's command watchdog);
* ``forged-peer``            a foreign zenoh peer publishing forged and replayed commands,
                             measurements, stop requests and log records during the run;
* ``full-disk``              a filler takes all the free space of the 64 MB tmpfs holding the log
                             (a private mount namespace, ``unshare -rm``; skipped where refused).

Per fault: time from the fault to the loop's stop, to the actuator at rest and to the
coordinator's exit [ms] (wall clock, this host), the largest command step the actuator executed
[mm] (the specimen's own count, ramp-down included, against its per-step limit
``max_velocity * dt``), the exit code, whether the log reads with the plain ``mcap`` reader and
whether it has its summary; for the forged peer the messages sent and accepted.  The 1-minute
load average is printed before and after.  ``--json`` writes the rows.

    python tools/fault_figures.py [--clock realtime|lockstep] [--rate 2048] [--duration 4]
                                  [--max-lag N] [--only NAME ...] [--json FILE]

The fault is injected once the run is under way (a passive zenoh peer has seen half a second of
commands go by; two seconds for SIGKILL, so the log has been flushed at least once).

The 10 x 60 s real-time runs at 2048 Hz are ``python tools/bench_loop.py --rates 2048 --clocks
realtime --repeats 10 --duration 60`` (its ``finished k/n`` column).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import zenoh

ROOT = Path(__file__).resolve().parent.parent
SEED = ROOT / "scenarios" / "cable_imd_mode3.toml"
FAULTS = (
    "sigint",
    "sigterm",
    "sighup",
    "coordinator-sigkill",
    "specimen-sigkill",
    "specimen-pause-300ms",
    "specimen-gc-106ms",
    "specimen-sigstop",
    "coordinator-pause-1s",
    "forged-peer",
    "full-disk",
)
#: Size of the tmpfs the full-disk fault fills.
DISK = "64m"


def scenario(rate: float, duration: float, max_lag: int | None) -> str:
    """The seed scenario at ``rate`` for ``duration``; ``max_lag`` None keeps the default
    watchdog (10 ms of steps)."""
    text = SEED.read_text()
    text = re.sub(r"^rate = .*$", f"rate = {rate}", text, flags=re.M)
    if max_lag is not None:
        text = text.replace("[loop]\n", f"[loop]\nmax_lag = {max_lag}\n")
    return re.sub(r"^duration = .*$", f"duration = {duration}", text, flags=re.M)


def wait_until_running(
    endpoint: str, run_id: str, commands: int, timeout: float, coordinator: subprocess.Popen
) -> bool:
    """Block until ``commands`` commands of the run have crossed zenoh (a passive peer counts
    them; they are sealed, it cannot read them); False if the coordinator ended first or
    ``timeout`` [s] passed."""
    from rths.wire.transport import RunKeys, ZenohEndpoints, session_config

    seen = threading.Event()
    count = [0]

    def on_command(sample: zenoh.Sample) -> None:
        count[0] += 1
        if count[0] >= commands:
            seen.set()

    with zenoh.open(session_config(ZenohEndpoints(connect=(endpoint,)))) as session:
        session.declare_subscriber(RunKeys(run_id).command, on_command)
        deadline = time.monotonic() + timeout
        while not seen.wait(0.2):
            if coordinator.poll() is not None or time.monotonic() > deadline:
                return False
        return True


def read_log(path: Path) -> tuple[bool, dict, dict]:
    """(readable, metadata, specimen summary) with the plain mcap reader."""
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as f:
            reader = make_reader(f)
            spec = {}
            for _, channel, message in reader.iter_messages():
                if channel.topic == "rths/specimen/summary":
                    spec = json.loads(message.data)
        with open(path, "rb") as f:
            meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
        return True, meta, spec
    except Exception:  # any failure to read is the figure
        return False, {}, {}


def spec_summary(stderr: str) -> dict:
    for line in reversed(stderr.splitlines()):
        if line.startswith("specimen summary: "):
            return json.loads(line[len("specimen summary: ") :])
    return {}


def forger(endpoint: str, run_id: str, done: threading.Event, counts: dict) -> None:
    from rths.wire.auth import RunSecret
    from rths.wire.codec import Command, LogRecord, Measurement
    from rths.wire.transport import RunKeys, ZenohEndpoints, session_config

    keys = RunKeys(run_id)
    captured: list[tuple[str, bytes]] = []
    with zenoh.open(session_config(ZenohEndpoints(connect=(endpoint,)))) as session:
        session.declare_subscriber(
            keys.command, lambda s: captured.append(("c", s.payload.to_bytes()))
        )
        session.declare_subscriber(
            keys.measurement, lambda s: captured.append(("m", s.payload.to_bytes()))
        )
        wrong = RunSecret.new()
        cmd, meas = wrong.sealer("command"), wrong.sealer("measurement")
        sent = k = 0
        while not done.is_set():
            k += 1
            for key, payload in (
                (keys.command, Command(k, k, 0.04).pack()),
                (keys.command, cmd.seal(Command(k, k, 0.04).pack())),
                (keys.measurement, Measurement(k, k, 0.03, 1e3, 0).pack()),
                (keys.measurement, meas.seal(Measurement(k, k, 0.03, 1e3, 0).pack())),
                (keys.stop, json.dumps({"reason": "forged stop"}).encode()),
                (keys.log("specimen"), LogRecord(k, k, {"force": 1e9}).encode()),
                (keys.log("specimen/summary"), LogRecord(k, k, {"steps": 1}).encode()),
            ):
                session.put(key, payload)
                sent += 1
            for kind, frame in captured[-2:]:
                session.put(keys.command if kind == "c" else keys.measurement, frame)
                sent += 1
            time.sleep(0.002)
        counts["sent"] = sent


def _fill(folder: Path) -> None:
    """Take all the free space of the file system holding ``folder``."""
    st = os.statvfs(folder)
    free = st.f_bavail * st.f_frsize
    with open(folder / "filler", "wb") as f:
        for size in (free, free - (1 << 16), free - (1 << 20)):
            try:
                os.posix_fallocate(f.fileno(), 0, max(size, 1))
                return
            except OSError:
                continue


def _writer_processes(pid: int) -> list[int]:
    """Pids of the MCAP writer processes (``rths.log.writer.writer_child``) started by ``pid``."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        for child in (task / "children").read_text().split():
            with contextlib.suppress(OSError):
                if b"rths.log.writer.writer_child" in Path(f"/proc/{child}/cmdline").read_bytes():
                    found.append(int(child))
    return found


def _inject(fault: str, coord: subprocess.Popen, spec: subprocess.Popen, tmp: Path) -> None:
    if fault in ("sigint", "sigterm", "sighup"):
        coord.send_signal(getattr(signal, fault.upper()))
    elif fault == "coordinator-sigkill":
        coord.kill()
    elif fault == "specimen-sigkill":
        spec.kill()
    elif fault.startswith("specimen"):
        os.kill(spec.pid, signal.SIGSTOP)
        if fault != "specimen-sigstop":
            time.sleep(0.3 if "300ms" in fault else 0.106)
            os.kill(spec.pid, signal.SIGCONT)
    elif fault == "coordinator-pause-1s":
        os.kill(coord.pid, signal.SIGSTOP)
        time.sleep(1.0)
        os.kill(coord.pid, signal.SIGCONT)
    elif fault == "full-disk":
        _fill(tmp)


def run_fault(
    fault: str, clock: str, rate: float, duration: float, max_lag: int | None, tmp: Path
) -> dict:
    """Inject ``fault`` into one run (module docstring); its row of the table."""
    from rths.wire.auth import RunSecret, write_secret_file
    from rths.wire.transport import loopback_endpoint

    scn = tmp / f"{fault}.toml"
    scn.write_text(scenario(rate, duration, max_lag))
    out = tmp / f"{fault}.mcap"
    secret = write_secret_file(tmp / f"{fault}.secret", RunSecret.new())
    endpoint = loopback_endpoint()
    run_id = f"fault-{fault}-{os.getpid()}"
    common = ["--run-id", run_id, "--secret-file", str(secret), "--clock", clock]
    rths = [sys.executable, "-m", "rths"]
    coord = subprocess.Popen(
        [*rths, "run", str(scn), "--out", str(out), "--listen", endpoint,
         "--external-specimen", "--no-progress", *common],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    spec = subprocess.Popen(
        [*rths, "specimen", str(scn), "--connect", endpoint, *common],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    # SIGKILL: after 2 s, so the recorder's periodic flush has put whole chunks on the disk
    lead = 2.0 if fault == "coordinator-sigkill" else 0.5
    running = wait_until_running(endpoint, run_id, round(lead * rate), 120.0, coord)
    fault_ns = time.monotonic_ns()
    counts: dict = {}
    done = threading.Event()
    attacker = None
    writers: list[int] = []
    if not running:
        pass
    elif fault == "forged-peer":
        attacker = threading.Thread(target=forger, args=(endpoint, run_id, done, counts))
        attacker.start()
    else:
        writers = _writer_processes(coord.pid) if fault == "coordinator-sigkill" else []
        _inject(fault, coord, spec, tmp)
    try:
        stdout, stderr = coord.communicate(timeout=120)
        exited_ms = (time.monotonic_ns() - fault_ns) / 1e6
    finally:
        done.set()
        if attacker is not None:
            attacker.join()
        if fault == "specimen-sigstop":
            os.kill(spec.pid, signal.SIGCONT)
    try:
        _, spec_err = spec.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        spec.kill()
        _, spec_err = spec.communicate()
    log = out
    if fault == "coordinator-sigkill":  # the writer finished the log; recover adds the summary
        for pid in writers:
            with contextlib.suppress(ProcessLookupError):
                fd = os.pidfd_open(pid)
                select.select([fd], [], [], 60.0)  # readable once the writer has exited
                os.close(fd)
        subprocess.run([*rths, "recover", str(out)], capture_output=True, check=False)
        log = out.with_name(f"{out.stem}.recovered.mcap")
    readable, meta, logged = read_log(log)
    figures = spec_summary(spec_err) or logged
    summary = meta.get("rths.summary", {})
    dt = 1.0 / rate
    row = {
        "fault": fault,
        "clock": clock,
        "fault_during_run": running,
        "exit": coord.returncode,
        "stopped": summary.get("stopped", "") or "",
        "loop_stop_ms": None,
        "at_rest_ms": None,
        "exited_ms": exited_ms if running else None,
        "largest_step_mm": 1e3 * float(figures.get("largest_command_step", float("nan"))),
        "step_limit_mm": 1e3 * 0.5 * dt,
        "readable": readable,
        "summary": bool(summary),
        "recovered": log != out,
        "specimen_reason": figures.get("stop_reason", ""),
        "ramp_steps": figures.get("ramp_down_steps"),
        "gc_in_loop": (
            summary.get("gc_collections_in_loop"),
            figures.get("gc_collections_in_loop"),
        ),
        "left_behind": sorted(
            p.name
            for p in tmp.iterdir()
            if p.name.startswith(fault) and p.suffix not in (".toml", ".mcap", ".secret")
        ),  # fmt: skip
    }
    if not running:
        row["stopped"] = "(fault not injected: the run had already stopped) " + row["stopped"]
    elif summary.get("loop_ended_monotonic_ns"):
        row["loop_stop_ms"] = (int(summary["loop_ended_monotonic_ns"]) - fault_ns) / 1e6
    elif fault == "coordinator-sigkill":
        row["loop_stop_ms"] = 0.0  # killed: the loop stopped with the signal
    if running and figures.get("at_rest_ns"):
        row["at_rest_ms"] = (figures["at_rest_ns"] - fault_ns) / 1e6
    if running and not summary.get("stopped") and fault != "coordinator-sigkill":
        row["loop_stop_ms"] = row["at_rest_ms"] = None  # it ran to its end: no stop to time
    ended = [ln for ln in stderr.splitlines() if ln.strip()]
    row["stderr"] = ended[-1] if ended else ""
    if fault == "forged-peer":
        row["forged_sent"] = counts.get("sent", 0)
        # dropped by the coordinator (measurements, stops, log records) and by the specimen
        # (commands, stops)
        row["forged_dropped"] = (
            int(summary.get("auth_forged", 0))
            + int(summary.get("auth_replayed", 0))
            + int(figures.get("auth_forged_dropped", 0))
            + int(figures.get("auth_replayed_dropped", 0))
        )
        # accepted: a forged message the loop or the specimen used -- the run would have
        # stopped (a forged stop, a jump) or its specimen would count it accepted
        row["forged_accepted"] = 0 if not row["stopped"] else "see stopped"
    return row


def full_disk(clock: str, rate: float, duration: float, max_lag: int | None) -> dict | None:
    """The full-disk fault in a private mount namespace (a tmpfs of :data:`DISK` mounted over a
    fresh folder); None where that is not allowed."""
    import shutil

    if (
        shutil.which("unshare") is None
        or subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode
    ):
        return None
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run(
            ["unshare", "-rm", sys.executable, __file__, "--inner-full-disk", tmp,
             "--clock", clock, "--rate", str(rate), "--duration", str(duration),
             *([] if max_lag is None else ["--max-lag", str(max_lag)])],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
    if done.returncode:
        raise RuntimeError(f"full-disk fault failed: {done.stderr.strip()[-500:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _inner_full_disk(args: argparse.Namespace) -> None:
    disk = Path(args.inner_full_disk)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={DISK}", "tmpfs", str(disk)], check=True)
    row = run_fault("full-disk", args.clock, args.rate, args.duration, args.max_lag, disk)
    print(json.dumps(row))


def _cell(value: float | None, fmt: str = ".0f") -> str:
    return "–" if value is None else format(value, fmt)


def _step(mm: float) -> str:
    return "– (process dead)" if mm != mm else f"{mm:.4f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clock", choices=("realtime", "lockstep"), default="realtime")
    ap.add_argument("--rate", type=float, default=2048.0)
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument(
        "--max-lag",
        type=int,
        default=None,
        help="[loop] max_lag of the runs (the watchdog) [steps]; default: the scenario's (10 ms)",
    )
    ap.add_argument("--only", nargs="*", choices=FAULTS, default=list(FAULTS))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--inner-full-disk", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.inner_full_disk:
        _inner_full_disk(args)
        return
    load = os.getloadavg()
    print(f"load before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", file=sys.stderr)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fault in args.only:
            if fault == "full-disk":
                row = full_disk(args.clock, args.rate, args.duration, args.max_lag)
                if row is None:
                    print("full-disk: skipped (no private mount namespace)", file=sys.stderr)
                    continue
            else:
                row = run_fault(
                    fault, args.clock, args.rate, args.duration, args.max_lag, Path(tmp)
                )
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)
    after = os.getloadavg()
    print(
        f"{args.clock}, {args.rate:g} Hz, {args.duration:g} s runs, max_lag "
        f"{'default' if args.max_lag is None else args.max_lag}; "
        f"load (1/5/15 min) before {load[0]:.2f}/{load[1]:.2f}/{load[2]:.2f}, after "
        f"{after[0]:.2f}/{after[1]:.2f}/{after[2]:.2f} on {os.cpu_count()} cores"
    )
    print(
        "| fault | → loop stopped [ms] | → actuator at rest [ms] | → coordinator exited [ms] "
        "| largest command step [mm] (limit) | exit | log readable | summary | stopped |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        extra = ""
        if r["fault"] == "forged-peer":
            extra = (
                f" (forged sent {r['forged_sent']}, dropped {r['forged_dropped']}, "
                f"accepted {r['forged_accepted']})"
            )
        readable = ("y" if r["readable"] else "n") + (" (recover)" if r["recovered"] else "")
        print(
            f"| {r['fault']}{extra} | {_cell(r['loop_stop_ms'])} | {_cell(r['at_rest_ms'])} "
            f"| {_cell(r['exited_ms'])} | {_step(r['largest_step_mm'])} "
            f"({r['step_limit_mm']:.4f}) | {r['exit']} | {readable} | "
            f"{'y' if r['summary'] else 'n'} | {r['stopped'] or 'ran to the end'} |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
