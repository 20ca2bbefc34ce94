"""The hostile-input corpus (``tests/bad_inputs``): its cases and how to run each one.

``tests/bad_inputs/cases.toml`` lists every file with the regex its one-line error must match;
the folder says which command gets the file (see the manifest's header).  Shared by
``tests/test_bad_inputs.py`` (in process) and ``tools/probe_inputs.py`` (the console script in
subprocesses, for the figure).
"""

from __future__ import annotations

import math
import shlex
import tomllib
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
CORPUS = HERE / "bad_inputs"
REPO = HERE.parent
NOMINAL = REPO / "scenarios" / "nominal" / "nominal_seed_simplified.toml"
SEED = REPO / "scenarios" / "cable_imd_mode3.toml"

__all__ = ["CORPUS", "Case", "Fixtures", "cases", "make_fixtures"]


@dataclass(frozen=True)
class Case:
    """One invocation: the corpus file, the argv template and the regex of the error line."""

    id: str
    file: Path
    argv: str
    expect: str
    code: int = 2


@dataclass(frozen=True)
class Fixtures:
    """Paths the argv templates refer to (``{seed}``, ``{good_csv}``, ...)."""

    seed: Path
    good_csv: Path
    good_log: Path | None


_DEFAULT = {
    "scenarios": ["run {file} --out {tmp}/out.mcap --no-progress"],
    "nominal": ["diagnose {good_csv} --nominal {file} --quiet"],
    "csv": ["diagnose {file} --nominal {nominal} --quiet"],
    "mcap": [
        "report {file} --out {tmp}/report --no-mock",
        "check {file} --max-rmse 5",
        "replay {file} --speed 1000000 --listen tcp/127.0.0.1:0",
        "diagnose {file} --nominal {nominal} --quiet",
    ],
}


def cases() -> list[Case]:
    """Every case of the manifest (an ``mcap/`` file gives four)."""
    manifest = tomllib.loads((CORPUS / "cases.toml").read_text(encoding="utf-8"))
    out = []
    for rel, entry in sorted(manifest.items()):
        folder = rel.split("/", 1)[0]
        path = CORPUS / rel
        if folder == "argv":
            templates = [path.read_text(encoding="utf-8").strip()]
        elif "argv" in entry:
            templates = [entry["argv"]]
        elif folder == "mcap_cut":
            continue  # damaged but readable logs: tests/test_recover.py
        else:
            templates = _DEFAULT[folder]
        for template in templates:
            command = template.split(" ", 1)[0] if template else "(none)"
            if command in entry.get("valid_for", ()):
                continue  # a usable input for this command
            suffix = f"[{command}]" if len(templates) > 1 else ""
            out.append(Case(rel + suffix, path, template, entry["expect"]))
    return out


def argv(case: Case, fx: Fixtures, tmp: Path) -> list[str]:
    """The case's argument vector with its placeholders filled in."""
    values = {
        "file": case.file,
        "dir": case.file.parent,
        "tmp": tmp,
        "seed": fx.seed,
        "nominal": NOMINAL,
        "good_csv": fx.good_csv,
        "good_log": fx.good_log,
    }
    return [part.format(**values) for part in shlex.split(case.argv)]


def make_fixtures(folder: Path, good_log: Path | None = None) -> Fixtures:
    """A short copy of the seed scenario and a plausible CSV record in ``folder``."""
    seed = folder / "seed_short.toml"
    seed.write_text(
        SEED.read_text(encoding="utf-8").replace("duration = 20.0", "duration = 0.25", 1),
        encoding="utf-8",
    )
    rate, n = 200.0, 600
    rows = ["time,command,measured,force"]
    for k in range(n):
        t = (k + 1) / rate
        u = 1e-3 * math.sin(2 * math.pi * 2.0 * t) + 2e-4 * math.sin(2 * math.pi * 7.0 * t)
        y = 1e-3 * math.sin(2 * math.pi * 2.0 * (t - 0.02))
        y += 2e-4 * math.sin(2 * math.pi * 7.0 * (t - 0.02))
        a = -((2 * math.pi * 2.0) ** 2) * 1e-3 * math.sin(2 * math.pi * 2.0 * (t - 0.02))
        a -= (2 * math.pi * 7.0) ** 2 * 2e-4 * math.sin(2 * math.pi * 7.0 * (t - 0.02))
        rows.append(f"{t:.9g},{u:.9g},{y:.9g},{1589.0 * a:.9g}")
    good_csv = folder / "good.csv"
    good_csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return Fixtures(seed, good_csv, good_log)
