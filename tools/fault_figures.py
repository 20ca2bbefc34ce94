"""Fault figures of issue 10 (items 1-2): what happens to the actuator when a process of a
real-time run is stopped, paused or attacked.

Faults (seed scenario, ``realtime`` clock, coordinator and specimen as separate processes on this
machine, the specimen started here so its pid is known):

* ``specimen-pause-300ms``   SIGSTOP of the specimen, SIGCONT 0.3 s later;
* ``specimen-gc-106ms``      a 106 ms pause of the specimen (the full collection measured before
                             the loops were made immune to their collector), as SIGSTOP/SIGCONT;
* ``specimen-sigstop``       SIGSTOP of the specimen, resumed only after the coordinator ended;
* ``coordinator-pause-1s``   SIGSTOP of the coordinator for 1 s (the specimen's command watchdog);
* ``forged-peer``            a foreign zenoh peer publishing forged and replayed commands,
                             measurements, stop requests and log records during the run.

Per fault: time from the fault to the coordinator's stop and to the actuator at rest [ms] (wall
clock, this host), the largest command step the actuator executed [mm] (the specimen's own
count, ramp-down included, against its per-step limit ``max_velocity * dt``), whether the log
reads with the plain ``mcap`` reader, whether it has its summary; and for the forged peer the
messages sent and accepted.  Prints one table; ``--json`` writes the rows.

    python tools/fault_figures.py [--rate 2048] [--duration 4] [--max-lag 5] [--only NAME ...]

The fault is injected once the run is under way (a passive zenoh peer has seen half a second of
commands go by).
"""

from __future__ import annotations

import argparse
import json
import os
import re
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
    "specimen-pause-300ms",
    "specimen-gc-106ms",
    "specimen-sigstop",
    "coordinator-pause-1s",
    "forged-peer",
)


def scenario(rate: float, duration: float, max_lag: int) -> str:
    text = SEED.read_text()
    text = re.sub(r"^rate = .*$", f"rate = {rate}", text, flags=re.M)
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


def run_fault(fault: str, rate: float, duration: float, max_lag: int, tmp: Path) -> dict:
    from rths.wire.auth import RunSecret, write_secret_file
    from rths.wire.transport import loopback_endpoint

    scn = tmp / f"{fault}.toml"
    scn.write_text(scenario(rate, duration, max_lag))
    out = tmp / f"{fault}.mcap"
    secret = write_secret_file(tmp / f"{fault}.secret", RunSecret.new())
    endpoint = loopback_endpoint()
    run_id = f"fault-{fault}-{os.getpid()}"
    common = ["--run-id", run_id, "--secret-file", str(secret)]
    coord = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rths",
            "run",
            str(scn),
            "--clock",
            "realtime",
            "--out",
            str(out),
            "--listen",
            endpoint,
            "--external-specimen",
            "--no-progress",
            *common,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    spec = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rths",
            "specimen",
            str(scn),
            "--connect",
            endpoint,
            "--clock",
            "realtime",
            *common,
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    running = wait_until_running(endpoint, run_id, round(0.5 * rate), 120.0, coord)
    fault_ns = time.monotonic_ns()
    counts: dict = {}
    done = threading.Event()
    if fault.startswith("specimen"):
        os.kill(spec.pid, signal.SIGSTOP)
        if fault != "specimen-sigstop":
            time.sleep(0.3 if "300ms" in fault else 0.106)
            os.kill(spec.pid, signal.SIGCONT)
    elif fault == "coordinator-pause-1s":
        os.kill(coord.pid, signal.SIGSTOP)
        time.sleep(1.0)
        os.kill(coord.pid, signal.SIGCONT)
    else:
        attacker = threading.Thread(target=forger, args=(endpoint, run_id, done, counts))
        attacker.start()
    try:
        stdout, stderr = coord.communicate(timeout=120)
    finally:
        done.set()
        if fault == "forged-peer":
            attacker.join()
        if fault == "specimen-sigstop":
            os.kill(spec.pid, signal.SIGCONT)
    try:
        _, spec_err = spec.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        spec.kill()
        _, spec_err = spec.communicate()
    readable, meta, logged = read_log(out)
    figures = spec_summary(spec_err) or logged
    summary = meta.get("rths.summary", {})
    dt = 1.0 / rate
    row = {
        "fault": fault,
        "fault_during_run": running,
        "exit": coord.returncode,
        "stopped": summary.get("stopped", "") or "",
        "coordinator_stop_ms": None,
        "at_rest_ms": None,
        "largest_step_mm": 1e3 * float(figures.get("largest_command_step", float("nan"))),
        "step_limit_mm": 1e3 * 0.5 * dt,
        "readable": readable,
        "summary": bool(summary),
        "specimen_reason": figures.get("stop_reason", ""),
        "ramp_steps": figures.get("ramp_down_steps"),
        "gc_in_loop": (
            summary.get("gc_collections_in_loop"),
            figures.get("gc_collections_in_loop"),
        ),
    }
    if not running:
        row["stopped"] = "(fault not injected: the run had already stopped) " + row["stopped"]
    elif summary.get("loop_ended_monotonic_ns"):
        row["coordinator_stop_ms"] = (int(summary["loop_ended_monotonic_ns"]) - fault_ns) / 1e6
    if running and figures.get("at_rest_ns"):
        row["at_rest_ms"] = (figures["at_rest_ns"] - fault_ns) / 1e6
    ended = [ln for ln in stderr.splitlines() if "stopped early" in ln]
    row["stderr"] = ended[-1] if ended else stderr.strip().splitlines()[-1:] or ""
    if fault == "forged-peer":
        row["forged_sent"] = counts.get("sent", 0)
        row["forged_dropped"] = int(summary.get("auth_forged", 0)) + int(
            summary.get("auth_replayed", 0)
        )
        row["forged_accepted"] = 0 if summary.get("stopped", "") == "" else "see stopped"
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=2048.0)
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument(
        "--max-lag", type=int, default=5, help="[loop] max_lag of the runs (the watchdog) [steps]"
    )
    ap.add_argument("--only", nargs="*", choices=FAULTS, default=list(FAULTS))
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    print(f"load: {os.getloadavg()}", file=sys.stderr)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fault in args.only:
            rows.append(run_fault(fault, args.rate, args.duration, args.max_lag, Path(tmp)))
            print(json.dumps(rows[-1]), file=sys.stderr)
    print(
        "| fault | fault → loop stopped [ms] | fault → actuator at rest [ms] | largest command "
        "step [mm] (limit) | log readable | summary | stopped |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        rest = "–" if r["at_rest_ms"] is None else f"{r['at_rest_ms']:.0f}"
        stop = "–" if r["coordinator_stop_ms"] is None else f"{r['coordinator_stop_ms']:.0f}"
        extra = ""
        if r["fault"] == "forged-peer":
            extra = f" (forged sent {r['forged_sent']}, dropped {r['forged_dropped']})"
        print(
            f"| {r['fault']}{extra} | {stop} | {rest} | {r['largest_step_mm']:.4f} "
            f"({r['step_limit_mm']:.4f}) | {'y' if r['readable'] else 'n'} | "
            f"{'y' if r['summary'] else 'n'} | {r['stopped'] or 'ran to the end'} |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
