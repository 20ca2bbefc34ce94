"""Convert the friction-damper-with-backlash records to the diagnosis CSV contract.

    python tools/friction_damper_to_csv.py --out DIR [--data DIR] [--records NAME ...]

Data: ARTS Laboratory, University of South Carolina; Downey et al., Engineering Structures 113
(2016) 287-298 (CC BY-SA 4.0), found from ``--data DIR`` or ``RTHS_DATA`` (the folder that holds
``friction-damper/``); without it the tool prints one ``skipped: ...`` line and exits 0.

One ``<record>.csv`` per record in ``--out`` with the header ``time,command,measured,force``
in SI (s, m, m, N) at the recorded uniform 1024 Hz:

- ``command`` = ``measured`` = the damper displacement (no separate actuator command was
  recorded; use an identity actuator in the nominal);
- ``force`` = the friction-force channel (kip -> N), the channel the loop reading trusts
  (``friction_damper_loops.py``: it agrees with ``2 (act2 - act1)`` of the actuator channels to
  a few per cent), with the sign that makes it the device's restoring force: the mean of
  ``F v`` over the samples with ``|v| > 30 %`` of the peak velocity is positive (the device
  dissipates).  The recorded sign already satisfies this on every record; the sign used is in
  the manifest.  No offset is removed (the no-contact level is within 0.16 kN of zero).

``manifest.json`` maps each record to its kind (sine / eq), frequency [Hz], band tension [lb],
amplitude [in] and [m], file name, sample count, sampling interval and force sign.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from friction_damper_data import (
    IN_M,
    SKIP_MESSAGE,
    OneLineParser,
    Record,
    find_data_dir,
    list_records,
    load_record,
)
from friction_damper_reading import velocity

ATTRIBUTION = (
    "ARTS Laboratory, University of South Carolina; Downey et al., Engineering "
    "Structures 113 (2016) 287-298 (CC BY-SA 4.0)"
)
HEADER = "time,command,measured,force"


def restoring_sign(rec: Record) -> int:
    """+1 or -1: the sign that makes ``sign * force`` dissipate (mean ``F v > 0`` while moving).

    ``v`` is the derivative of the displacement; "moving" = ``|v| > 30 %`` of its peak.
    """
    v = velocity(rec.x, rec.dt)
    moving = np.abs(v) > 0.3 * np.abs(v).max()
    return 1 if float(np.mean(rec.force[moving] * v[moving])) >= 0.0 else -1


def columns(rec: Record) -> tuple[np.ndarray, int]:
    """``(table [n, 4] of time, command, measured, force in SI, force sign)`` of one record.

    Raises
    ------
    ValueError
        When the sampling is not uniform (steps differ by more than 1e-6 of the median).
    """
    dt = np.diff(rec.t)
    if np.max(np.abs(dt - rec.dt)) > 1e-6 * rec.dt:
        raise ValueError(f"{rec.name}: sampling is not uniform")
    sign = restoring_sign(rec)
    return np.column_stack([rec.t, rec.x, rec.x, sign * rec.force]), sign


def write_csv(path: Path, table: np.ndarray) -> None:
    """Write ``table`` under the ``time,command,measured,force`` header (9 significant digits)."""
    np.savetxt(path, table, delimiter=",", header=HEADER, comments="", fmt="%.9g")


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring); returns the exit code."""
    p = OneLineParser(prog="friction_damper_to_csv.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--data", help="folder holding friction-damper/ (default: $RTHS_DATA)")
    p.add_argument("--out", type=Path, required=True, help="folder for the CSVs and manifest.json")
    p.add_argument("--records", nargs="+", metavar="NAME", help="record names (default: all)")
    args = p.parse_args(argv)
    folder = find_data_dir(args.data)
    if folder is None:
        print(SKIP_MESSAGE)
        return 0
    names = list_records(folder)
    unknown = sorted(set(args.records or []) - set(names))
    if unknown:
        p.error(f"unknown record(s) {', '.join(unknown)}; have: {', '.join(names)}")
    names = [n for n in names if not args.records or n in args.records]
    manifest: dict[str, object] = {
        "attribution": ATTRIBUTION,
        "header": HEADER,
        "units": "s, m, m, N",
        "records": {},
    }
    try:
        args.out.mkdir(parents=True, exist_ok=True)
        for n in names:
            rec = load_record(folder, n)
            table, sign = columns(rec)
            write_csv(args.out / f"{n}.csv", table)
            manifest["records"][n] = {  # type: ignore[index]
                "kind": rec.kind,
                "frequency_hz": rec.frequency_hz,
                "tension_lb": rec.tension_lb,
                "amplitude_in": rec.amplitude_in,
                "amplitude_m": None if rec.amplitude_in is None else rec.amplitude_in * IN_M,
                "file": f"{n}.csv",
                "samples": int(table.shape[0]),
                "dt_s": rec.dt,
                "force_sign": sign,
            }
            print(
                f"{args.out / (n + '.csv')}: {table.shape[0]} samples at {1 / rec.dt:g} Hz, "
                f"force sign {sign:+d}"
            )
        (args.out / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    except OSError as e:
        print(f"friction_damper_to_csv.py: error: {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    except ValueError as e:
        print(f"friction_damper_to_csv.py: error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {args.out / 'manifest.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
