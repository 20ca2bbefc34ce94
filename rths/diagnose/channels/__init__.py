"""The channels a diagnosis compares: signal conditioning, the replay channels and their split.

signals   zero-phase smoothing, derivatives, white-noise level, TF replay in the DAQ timing
          convention, fractional shifts, the running load amplitude (S0 Eq.17-18's ``A``)
rest      the transducers' noise colour, read where the records start at rest
channel   a channel: segments, noise levels, its noise floor; the identification / held-out split
build     the ``measured`` (actuator), ``force`` and ``displacement`` (specimen, either way round)
          channels built from records against the nominal
"""

from rths.diagnose.channels.build import (
    actuator_channel,
    displacement_channel,
    force_deviation,
    specimen_channel,
)
from rths.diagnose.channels.channel import (
    DEFAULT_CUTOFF,
    EDGE_SECONDS,
    TIME_BLOCKS,
    Channel,
    Segment,
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
