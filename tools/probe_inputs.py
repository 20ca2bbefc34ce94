"""Run the hostile-input corpus (``tests/bad_inputs``) through the real console script, one
subprocess per case, and count how many give what the README promises: exit code 2 and exactly
one line on stderr, matching the case's regex, with no traceback.

``tests/test_bad_inputs.py`` runs the same cases in process (fast); this is the figure a user's
shell sees -- warnings printed by the interpreter, argparse's usage, thread tracebacks included.

Usage::

    python tools/probe_inputs.py [--jobs 2] [--only SUBSTRING] [--show-bad]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from _corpus import Case, Fixtures, argv, cases, make_fixtures


def probe(case: Case, fx: Fixtures, base: Path) -> tuple[Case, int, list[str], float, bool]:
    """Run one case; (case, exit code, stderr lines, seconds, as promised)."""
    tmp = Path(tempfile.mkdtemp(dir=base))
    start = time.monotonic()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "rths", *argv(case, fx, tmp)],
            capture_output=True,
            text=True,
            timeout=600,
            cwd=tmp,
        )
        code, err = done.returncode, done.stderr
    except subprocess.TimeoutExpired:
        code, err = -9, "timeout after 600 s\n"
    lines = [line for line in err.splitlines() if line.strip()]
    ok = (
        code == 2
        and len(lines) == 1
        and "Traceback" not in err
        and re.search(case.expect, lines[0], re.IGNORECASE) is not None
    )
    return case, code, lines, time.monotonic() - start, ok


def main() -> None:
    """Probe every case and print the count."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", default="")
    parser.add_argument("--show-bad", action="store_true")
    args = parser.parse_args()
    base = Path(tempfile.mkdtemp(prefix="rths-probe-"))
    fx = make_fixtures(base)
    log = base / "good.mcap"
    subprocess.run(
        [sys.executable, "-m", "rths", "run", str(fx.seed), "--clock", "fast", "--out", str(log),
         "--no-progress"],
        check=True,
        capture_output=True,
    )  # fmt: skip
    fx = Fixtures(fx.seed, fx.good_csv, log)
    chosen = [c for c in cases() if args.only in c.id]
    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda c: probe(c, fx, base), chosen))
    good = [r for r in results if r[4]]
    files = {r[0].file for r in results}
    print(
        f"{len(results)} cases from {len(files)} corpus files: {len(good)} gave exit 2 and one "
        f"stderr line naming the problem; {len(results) - len(good)} did not"
    )
    print(f"slowest case: {max(r[3] for r in results):.1f} s")
    if args.show_bad:
        for case, code, lines, seconds, ok in results:
            if not ok:
                print(f"  {case.id}: exit {code}, {len(lines)} lines: {lines[:2]}")


if __name__ == "__main__":
    main()
