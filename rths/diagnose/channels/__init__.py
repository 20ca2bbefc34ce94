"""The channels a diagnosis compares: signal conditioning, the replay channels and their split.

signals   zero-phase smoothing, derivatives, white-noise level, TF replay in the DAQ timing
          convention, fractional shifts, the running load amplitude (S0 Eq.17-18's ``A``)
channel   the ``measured`` (actuator), ``force`` and ``displacement`` (specimen, either way round)
          channels, their noise floors and the identification / held-out split
"""

from rths.diagnose.channels.channel import (
    DEFAULT_CUTOFF,
    EDGE_SECONDS,
    TIME_BLOCKS,
    Channel,
    Segment,
    actuator_channel,
    displacement_channel,
    force_deviation,
    specimen_channel,
    split_roles,
)

__all__ = [
    "DEFAULT_CUTOFF",
    "EDGE_SECONDS",
    "TIME_BLOCKS",
    "Channel",
    "Segment",
    "actuator_channel",
    "displacement_channel",
    "force_deviation",
    "specimen_channel",
    "split_roles",
]
