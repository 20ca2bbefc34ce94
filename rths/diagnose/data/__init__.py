"""The diagnosis's inputs: test records, the nominal model, and the project's own labelled records.

records     CSV files of the section-7 contract and ``rths run`` MCAP logs (timing convention)
nominal     ``NOMINAL.toml``: what the simulation believes (the baseline's parameters)
synthetic   records made by the project's emulated lab with hidden effects (blind suite, tests)
"""

from rths.diagnose.data.nominal import (
    ActuatorNominal,
    NominalModel,
    SpecimenNominal,
    load_nominal,
    nominal_toml,
    parse_nominal,
)
from rths.diagnose.data.records import (
    COLUMNS,
    MIN_DURATION,
    SAMPLING_TOLERANCE,
    Record,
    align_log,
    load_record,
    read_csv,
    read_mcap,
    write_csv,
)

__all__ = [
    "COLUMNS",
    "MIN_DURATION",
    "SAMPLING_TOLERANCE",
    "ActuatorNominal",
    "NominalModel",
    "Record",
    "SpecimenNominal",
    "align_log",
    "load_nominal",
    "load_record",
    "nominal_toml",
    "parse_nominal",
    "read_csv",
    "read_mcap",
    "write_csv",
]
