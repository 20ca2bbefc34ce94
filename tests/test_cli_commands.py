"""The sub-commands are found wherever they sit under :mod:`rths.commands` (sub-packages group
them by concern), listed in the order of their names, helpers left out."""

from __future__ import annotations

import re

from _cli import run_cli

# The README's command list: what a user can type after ``rths``.
COMMANDS = [
    "check",
    "compare",
    "damping",
    "diagnose",
    "kinds",
    "recover",
    "replay",
    "report",
    "run",
    "specimen",
    "study",
    "sweep",
]


def test_every_sub_command_is_listed_once_in_name_order() -> None:
    result = run_cli(["--help"])
    assert result.code == 0, result.err
    listed = re.findall(r"^    ([a-z_]+)  ", result.out, flags=re.M)  # "    name   its help"
    assert listed == COMMANDS, result.out


def test_a_command_in_a_sub_package_runs() -> None:
    result = run_cli(["recover", "--help"])  # rths/commands/logs/recover.py
    assert result.code == 0 and result.out.startswith("usage: rths recover"), result.err
