"""Sim-to-real gap diagnosis (design.md section 7): where the gap lies, which effects the nominal
model lacks, and how far they close the gap on held-out data.

Layout::

    data/       records (CSV, MCAP; the DAQ timing convention), NOMINAL.toml, own labelled records
    channels/   signal conditioning, the actuator and specimen channels, their noise floors
    effects/    the models: re-calibrated baseline + candidate effects (registry EFFECTS)
    search/     global identification, noise floors, greedy selection on held-out data
    residuals   decomposition of a residual: significance, band, phase of the cycle, windows
    structure   the structure channel of ``rths run`` logs
    verdict     the whole diagnosis, in order of work                 -> Diagnosis
    answer      the Diagnosis and its JSON document
    report      terminal table and figures
    suite       a labelled suite's case folder as one campaign task (tools/score_diagnosis.py)

Use::

    from rths.diagnose import Options, diagnose, load_nominal, load_record
    d = diagnose([load_record("run1.csv"), load_record("run2.csv")], load_nominal("NOMINAL.toml"))
    d.verdict, d.params, d.effects, d.to_dict()
"""

from rths.diagnose.data.nominal import NominalModel, load_nominal, parse_nominal
from rths.diagnose.data.records import Record, load_record
from rths.diagnose.effects import EFFECTS
from rths.diagnose.verdict import Diagnosis, Options, diagnose

__all__ = [
    "EFFECTS",
    "Diagnosis",
    "NominalModel",
    "Options",
    "Record",
    "diagnose",
    "load_nominal",
    "load_record",
    "parse_nominal",
]
