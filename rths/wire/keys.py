"""Zenoh key expressions of a run (no zenoh import): every key lives under ``rths/<run-id>/``, so
two runs never cross-talk (:class:`RunKeys`), and run ids are fresh and safe (:func:`new_run_id`).
"""

from __future__ import annotations

import re
import secrets
import time
from dataclasses import dataclass
from typing import Literal

from rths.core.errors import ParameterError

__all__ = ["ROLES", "Role", "RunKeys", "check_run_id", "new_run_id"]

Role = Literal["coordinator", "specimen"]
ROLES: tuple[Role, Role] = ("coordinator", "specimen")

_RUN_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_LOG_NAME = re.compile(r"^[A-Za-z0-9_.-]+(/[A-Za-z0-9_.-]+)*$")


def check_run_id(run_id: str) -> str:
    """Return ``run_id`` if it is 1-64 characters of ``[A-Za-z0-9_.-]`` starting with a letter or
    digit (no ``/``, ``*``, ``$``: it can never widen a key expression to another run).

    Parameters
    ----------
    run_id : str
        The candidate run id, e.g. ``"20250101T120000Z-3fa2c1"`` (:func:`new_run_id`).

    Raises
    ------
    ParameterError
        If ``run_id`` is not such a string.
    """
    if not isinstance(run_id, str) or not _RUN_ID.match(run_id):
        raise ParameterError(
            f"run id must be 1-64 characters of [A-Za-z0-9_.-] starting with a letter or digit; "
            f"got {run_id!r}"
        )
    return run_id


def new_run_id() -> str:
    """A fresh run id: UTC time stamp and 6 random hex digits, e.g. ``20250101T120000Z-3fa2c1``."""
    return time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + secrets.token_hex(3)


@dataclass(frozen=True, slots=True)
class RunKeys:
    """The zenoh key expressions of one run, all under ``rths/<run_id>/``.

    ``run_id`` is 1-64 characters from ``[A-Za-z0-9_.-]`` starting with a letter or digit (no
    ``/``, ``*``, ``$``, so it can never widen a key expression to another run).

    Attributes
    ----------
    run_id : str
        The run's id (:func:`check_run_id`; :func:`new_run_id` makes a fresh one).
    """

    run_id: str

    def __post_init__(self) -> None:
        check_run_id(self.run_id)

    @property
    def root(self) -> str:
        """``rths/<run_id>``."""
        return f"rths/{self.run_id}"

    @property
    def command(self) -> str:
        """Actuator commands, coordinator → specimen (:class:`rths.wire.codec.Command`)."""
        return f"{self.root}/command"

    @property
    def measurement(self) -> str:
        """Measurements, specimen → coordinator (:class:`rths.wire.codec.Measurement`)."""
        return f"{self.root}/measurement"

    @property
    def loop(self) -> str:
        """Live copy of the loop record (:class:`rths.wire.codec.LogRecord`) for monitors; the MCAP
        log is written directly (not from this key)."""
        return f"{self.root}/loop"

    @property
    def events(self) -> str:
        """Run events (JSON): start, overruns, errors, stop."""
        return f"{self.root}/events"

    @property
    def stop(self) -> str:
        """Stop request (JSON ``{"reason": ...}``), coordinator → specimen."""
        return f"{self.root}/control/stop"

    def ready(self, role: Role) -> str:
        """Liveliness token of a process that is up and subscribed: ``control/ready/<role>``."""
        if role not in ROLES:
            raise ParameterError(f"role must be one of {ROLES}; got {role!r}")
        return f"{self.root}/control/ready/{role}"

    def warmup(self, role: Role) -> str:
        """Key of ``role``'s link warm-up frame (:meth:`rths.wire.presence.Presence.wait_for_peer`).

        Parameters
        ----------
        role
            ``"coordinator"`` or ``"specimen"``.
        """
        if role not in ROLES:
            raise ParameterError(f"role must be one of {ROLES}; got {role!r}")
        return f"{self.root}/control/warmup/{role}"

    @property
    def log_all(self) -> str:
        """``rths/<run_id>/log/**``: JSON log records any process may publish for the recorder."""
        return f"{self.root}/log/**"

    def log(self, name: str) -> str:
        """Key of the log stream ``name`` (recorded as MCAP topic ``rths/<name>``)."""
        if not isinstance(name, str) or not _LOG_NAME.match(name):
            raise ParameterError(f"log stream name must be like 'specimen' or 'a/b'; got {name!r}")
        return f"{self.root}/log/{name}"

    @property
    def specimen_state(self) -> str:
        """Internal state of the emulated specimen (JSON log records)."""
        return self.log("specimen")

    def topic_of(self, key: str) -> str:
        """MCAP topic of a log key: ``rths/<run>/log/<name>`` → ``rths/<name>``."""
        prefix = f"{self.root}/log/"
        if not key.startswith(prefix) or len(key) == len(prefix):
            raise ParameterError(f"key must start with {prefix!r}; got {key!r}")
        return "rths/" + key[len(prefix) :]
