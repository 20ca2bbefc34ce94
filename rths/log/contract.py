"""The log contract as documentation, generated from the channel declarations.

The README's table of the logged channels is the output of :func:`markdown` (a test keeps the two
equal): the channels are declared once, in the code that writes them (:data:`rths.runtime.loop.
LOOP_CHANNELS`, :data:`plants.lab.LAB_CHANNELS`, the compensators' and substructures'
``channels()``), and the MCAP schemas are generated from the same declarations, so the contract,
the schemas and the code cannot drift.  ``python -m rths.log.contract`` prints it.
"""

from __future__ import annotations

from collections.abc import Sequence

from controllers.model_based.lqg import LQGCompensator
from plants.cable.model import CABLE_CHANNELS
from plants.lab import LAB_CHANNELS
from rths.core.channels import Channel
from rths.runtime.loop import LOOP_CHANNELS

__all__ = ["markdown"]


def _table(channels: Sequence[Channel], prefix: str = "") -> list[str]:
    lines = ["| field | unit | meaning |", "|---|---|---|"]
    lines += [f"| `{prefix}{c.name}` | {c.unit} | {c.description} |" for c in channels]
    return lines


def markdown() -> str:
    """The README's log-contract tables."""
    lines = ["**`rths/loop`** (one message per step; `seq` = k, an integer):", ""]
    lines += _table(LOOP_CHANNELS)
    lines += ["", "then the compensator's channels as `ctrl_<name>` (`lqg`, `ff_lqg`):", ""]
    lines += _table(LQGCompensator.CHANNELS, "ctrl_")
    lines += [
        "",
        "and the substructure's as `sub_<name>` (`cable`; the device's only with one):",
        "",
    ]
    lines += _table(CABLE_CHANNELS, "sub_")
    lines += [
        "",
        "**`rths/specimen`** (one message per step, from the specimen process; `seq` = the "
        "command's k), then the actuator's state as `actuator.<name>`:",
        "",
    ]
    lines += _table(LAB_CHANNELS)
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(markdown(), end="")
