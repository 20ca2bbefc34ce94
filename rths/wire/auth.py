"""Authenticated messages of a run: a per-run secret and an HMAC on every message.

Anyone on the machine can connect a zenoh peer to the coordinator's endpoint, read the keys and
publish on them.  So every message a run exchanges -- commands, measurements, stop requests, log
records and the live copy -- is sealed with a check only a holder of the run's secret can compute,
and the receiver drops (and counts) every message whose check fails or that it has seen before.

Frame (little-endian)::

    0 counter u64 | 8 payload ... | -16 tag (16 bytes)
    tag = HMAC-SHA256(secret, domain || counter || payload)[:16]

``domain`` names the message kind and direction (e.g. ``b"command"``), so a sealed measurement can
never pass as a command.  ``counter`` starts at 1 and grows by one per message of a sender and
domain; a receiver accepts a frame only if its counter is above the last one it accepted
(:class:`Opener`), so a recorded frame replayed later is dropped as a *replay*.  A fresh secret per
run (:func:`new_secret`, 32 random bytes) means frames of one run never verify in another.

The secret never appears on a command line (``ps`` shows argv to every user): the coordinator
hands it to the specimen process on its standard input, or through a file readable only by its
owner for a specimen on another host (:func:`read_secret`, :func:`write_secret_file`).

Cost: one ``hmac.digest`` (OpenSSL, one shot) per message, about 1 µs.
"""

from __future__ import annotations

import hmac
import os
import secrets
import struct
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from rths.core.errors import ConfigError, ParameterError

__all__ = [
    "SECRET_ENV",
    "SECRET_BYTES",
    "TAG_BYTES",
    "Opener",
    "RunSecret",
    "Sealer",
    "new_secret",
    "read_secret",
    "write_secret_file",
]

T = TypeVar("T")

#: Bytes of a run secret.
SECRET_BYTES = 32
#: Bytes of the truncated HMAC-SHA256 tag (128 bits).
TAG_BYTES = 16
#: Environment variable a specimen started by hand may take the secret (hex) from.
SECRET_ENV = "RTHS_RUN_SECRET"
_COUNTER = struct.Struct("<Q")
OVERHEAD = _COUNTER.size + TAG_BYTES


def new_secret() -> bytes:
    """A fresh run secret (:data:`SECRET_BYTES` bytes from the OS's CSPRNG)."""
    return secrets.token_bytes(SECRET_BYTES)


class RunSecret:
    """The run's secret key; makes sealers and openers for each message domain.

    Parameters
    ----------
    key
        At least 16 bytes (a :func:`new_secret`).
    """

    def __init__(self, key: bytes) -> None:
        if not isinstance(key, bytes | bytearray) or len(key) < 16:
            raise ParameterError(f"run secret must be at least 16 bytes; got {len(key)} bytes")
        self._key = bytes(key)

    @classmethod
    def new(cls) -> RunSecret:
        """A fresh random secret."""
        return cls(new_secret())

    @classmethod
    def from_hex(cls, text: str) -> RunSecret:
        """Parse the hex form (:meth:`hex`).

        Parameters
        ----------
        text
            Hex digits (surrounding white space ignored).

        Raises
        ------
        ConfigError
            If ``text`` is not an even-length hex string of at least 32 digits.
        """
        try:
            key = bytes.fromhex(text.strip())
        except ValueError:
            raise ConfigError("run secret must be hex digits (as written by rths run)") from None
        if len(key) < 16:
            raise ConfigError(f"run secret must be at least 32 hex digits; got {2 * len(key)}")
        return cls(key)

    def hex(self) -> str:
        """The secret as hex digits (what goes on the specimen's stdin or in a secret file)."""
        return self._key.hex()

    def sealer(self, domain: str) -> Sealer:
        """A sealer for messages of ``domain`` (one per sender and domain).

        Parameters
        ----------
        domain
            Message kind and direction, e.g. ``"command"``.
        """
        return Sealer(self._key, domain)

    def opener(self, domain: str) -> Opener:
        """An opener for messages of ``domain`` (one per receiver and domain).

        Parameters
        ----------
        domain
            Message kind and direction, e.g. ``"command"``.
        """
        return Opener(self._key, domain)

    def __repr__(self) -> str:  # never print the key
        return "RunSecret(<hidden>)"


class Sealer:
    """Seals payloads of one domain: counter, payload, tag (see the module docstring).

    Parameters
    ----------
    key : bytes
        The run's secret key, at least 16 bytes (:func:`new_secret`: 32 random bytes).
    domain : str
        The message kind and direction, e.g. ``"command"``; part of every tag, so a frame of one
        domain never verifies in another.
    """

    __slots__ = ("_domain", "_key", "counter")

    def __init__(self, key: bytes, domain: str) -> None:
        self._key = key
        self._domain = domain.encode()
        self.counter = 0  #: counter of the last sealed frame

    def seal(self, payload: bytes) -> bytes:
        """The frame carrying ``payload``.

        Parameters
        ----------
        payload
            The message bytes.
        """
        self.counter += 1
        head = _COUNTER.pack(self.counter)
        tag = hmac.digest(self._key, self._domain + head + payload, "sha256")[:TAG_BYTES]
        return head + payload + tag


class Opener:
    """Checks frames of one domain and counts what it drops.

    Parameters
    ----------
    key : bytes
        The run's secret key, at least 16 bytes (:func:`new_secret`: 32 random bytes).
    domain : str
        The message kind and direction, e.g. ``"command"``; must match the sender's.

    Attributes
    ----------
    accepted, forged, replayed
        Frames accepted; dropped because the tag did not verify (or the frame was too short to
        carry one); dropped because their counter was not above the last accepted one.
    """

    __slots__ = ("_domain", "_key", "accepted", "forged", "last", "replayed")

    def __init__(self, key: bytes, domain: str) -> None:
        self._key = key
        self._domain = domain.encode()
        self.last = 0
        self.accepted = self.forged = self.replayed = 0

    def open(self, frame: bytes) -> bytes | None:
        """The payload of an authentic, fresh ``frame``; None (counted) otherwise.

        Parameters
        ----------
        frame
            A frame as received.
        """
        if len(frame) < OVERHEAD:
            self.forged += 1
            return None
        body, tag = frame[:-TAG_BYTES], frame[-TAG_BYTES:]
        expected = hmac.digest(self._key, self._domain + body, "sha256")[:TAG_BYTES]
        if not hmac.compare_digest(tag, expected):
            self.forged += 1
            return None
        (counter,) = _COUNTER.unpack_from(body)
        if counter <= self.last:
            self.replayed += 1
            return None
        self.last = counter
        self.accepted += 1
        return body[_COUNTER.size :]

    def decoder(self, decode: Callable[[bytes], T]) -> Callable[[bytes], T | None]:
        """``decode`` behind this opener: returns None for a dropped frame.

        Parameters
        ----------
        decode
            ``payload bytes -> message``.
        """

        def opened(frame: bytes) -> T | None:
            payload = self.open(frame)
            return None if payload is None else decode(payload)

        return opened

    def counts(self) -> dict[str, int]:
        """``{"accepted": .., "forged": .., "replayed": ..}``."""
        return {"accepted": self.accepted, "forged": self.forged, "replayed": self.replayed}


def read_secret(path: str | os.PathLike[str] | None = None, *, stdin: bool = False) -> RunSecret:
    """The run secret from a file, from standard input, or from :data:`SECRET_ENV`.

    Parameters
    ----------
    path
        A file holding the hex secret (must not be readable by group or others).
    stdin
        Read one line of hex from standard input (how ``rths run`` hands it to the specimen
        process it starts).

    Raises
    ------
    ConfigError
        If no secret is given, the file is readable by others, or the text is not a secret.
    """
    import sys

    if path is not None:
        p = Path(path)
        try:
            mode = p.stat().st_mode
            text = p.read_text()
        except OSError as exc:
            raise ConfigError(f"cannot read secret file '{p}': {exc.strerror}") from None
        if mode & 0o077:
            raise ConfigError(
                f"secret file '{p}' is readable by others (mode {mode & 0o777:o}); chmod 600 it"
            )
        return RunSecret.from_hex(text)
    if stdin:
        return RunSecret.from_hex(sys.stdin.readline())
    env = os.environ.get(SECRET_ENV)
    if env:
        return RunSecret.from_hex(env)
    raise ConfigError(
        f"no run secret: give --secret-file FILE (written by 'rths run --external-specimen') or "
        f"set {SECRET_ENV}"
    )


def write_secret_file(path: str | os.PathLike[str], secret: RunSecret) -> Path:
    """Write ``secret`` (hex) to a new file readable by its owner only (mode 600).

    Parameters
    ----------
    path
        The file (created or truncated).
    secret
        The run's secret.
    """
    p = Path(path)
    fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(secret.hex() + "\n")
    os.chmod(p, 0o600)
    return p
