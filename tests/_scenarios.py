"""Scenario texts for the loop/runner tests: the seed scenario shortened and variants of it."""

from __future__ import annotations

import re
from pathlib import Path

SEED = Path(__file__).resolve().parent.parent / "scenarios" / "cable_imd_mode3.toml"


def seed_text(**substitutions: str) -> str:
    """The seed scenario with regex substitutions (pattern -> replacement, multiline)."""
    text = SEED.read_text()
    for pattern, replacement in substitutions.items():
        new = re.sub(pattern, replacement, text, flags=re.M)
        assert new != text, f"pattern {pattern!r} did not match the seed scenario"
        text = new
    return text


def short(duration: float = 1.0, **substitutions: str) -> str:
    """The seed scenario cut to ``duration`` seconds."""
    return seed_text(**{r"^duration = 20.0": f"duration = {duration}"}, **substitutions)


#: The specimen replaced by exactly the [model] device (fixed damping, no amplitude law).
SAME_AS_MODEL = {
    r'^preset = "type_ii".*$': "inertance = 1589.0\nstiffness = 1.2e7\ndamping = 7971.57",
    r"^damping_ratio = 0.038.*$": "damping = 7971.57",
}
#: A perfect actuator (unit transfer function) and no compensation.
PERFECT_ACTUATOR = {
    r'^preset = "mts_identified".*$': "num = [1.0]\nden = [1.0]",
    r'^kind = "ff_lqg"': 'kind = "none"',
    r"^noise_rms = 1e-4.*$": "",
}
#: Noise-free, 30-bit converters.
QUIET = {
    r"^bits = 16": "bits = 30",
    r"^displacement_noise = 5e-4.*$": "displacement_noise = 0.0",
    r"^force_noise = 1e-3.*$": "force_noise = 0.0",
}
