"""Authenticated messages: a frame verifies only with the run's secret and only once; the
secret never needs argv; secret files must be private."""

from __future__ import annotations

import os

import pytest

from rths.core.errors import ConfigError, ParameterError
from rths.wire.auth import SECRET_ENV, RunSecret, read_secret, write_secret_file
from rths.wire.codec import Command


def test_sealed_frames_open_once_and_only_with_the_secret():
    secret = RunSecret.new()
    seal, open_ = secret.sealer("command"), secret.opener("command")
    frames = [seal.seal(Command(k, k * 10, 1e-3 * k).pack()) for k in range(5)]
    assert [Command.unpack(open_.open(f)).seq for f in frames] == list(range(5))
    assert open_.open(frames[2]) is None and open_.replayed == 1  # replay
    other = RunSecret.new().sealer("command").seal(Command(9, 0, 0.03).pack())
    assert open_.open(other) is None  # another run's (or a forger's) key
    tampered = bytearray(seal.seal(Command(5, 0, 0.001).pack()))
    tampered[20] ^= 1
    assert open_.open(bytes(tampered)) is None
    assert open_.open(b"short") is None
    assert secret.opener("measurement").open(seal.seal(b"x" * 24)) is None  # wrong domain
    assert open_.counts() == {"accepted": 5, "forged": 3, "replayed": 1}


def test_secret_round_trips_through_a_private_file(tmp_path):
    secret = RunSecret.new()
    path = write_secret_file(tmp_path / "run.secret", secret)
    assert oct(path.stat().st_mode & 0o777) == "0o600"
    assert read_secret(path).hex() == secret.hex()
    assert "hidden" in repr(secret) and secret.hex() not in repr(secret)


def test_a_secret_file_others_can_read_is_refused(tmp_path):
    path = write_secret_file(tmp_path / "s", RunSecret.new())
    os.chmod(path, 0o644)
    with pytest.raises(ConfigError, match="readable by others"):
        read_secret(path)


def test_secret_from_the_environment_and_clear_errors(monkeypatch):
    secret = RunSecret.new()
    monkeypatch.setenv(SECRET_ENV, secret.hex())
    assert read_secret().hex() == secret.hex()
    monkeypatch.delenv(SECRET_ENV)
    with pytest.raises(ConfigError, match="no run secret"):
        read_secret()
    with pytest.raises(ConfigError, match="hex digits"):
        RunSecret.from_hex("zz")
    with pytest.raises(ConfigError, match="at least 32 hex digits"):
        RunSecret.from_hex("abcd")
    with pytest.raises(ParameterError, match="at least 16 bytes"):
        RunSecret(b"short")
