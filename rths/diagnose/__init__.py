"""Sim-to-real gap diagnosis (design.md section 7): where the gap lies, which unmodelled effect
causes it, and how far it shrinks once modelled.

Pipeline (one module each)::

    data        CSV/MCAP records and their checks          -> Record
    nominal     NOMINAL.toml                               -> NominalModel
    channels    replay channels 'measured' (actuator) and 'force' (specimen), the split
    effects     baseline + candidate grey-box models (registry EFFECTS; the models live in
                _actuator_effects and _specimen_effects, their interface in _model)
    structure   the structure channel of an ``rths run`` log against the numerical mock run
    identify    variable-projection fit on identification data, held-out scoring, noise floors
    residuals   decomposition: NRMSE, significance vs the noise floor, band, phase, windows
    verdict     ranking with a complexity penalty, verdict, shrink     -> Diagnosis
    report      terminal table and figures
    synthetic   emulated-lab records with one hidden effect (blind suite, tests)

Use::

    from rths.diagnose import Options, diagnose, load_nominal, load_record
    d = diagnose([load_record("run1.csv"), load_record("run2.csv")], load_nominal("NOMINAL.toml"))
    d.verdict, d.params, d.to_dict()
"""

from rths.diagnose.data import Record, load_record
from rths.diagnose.effects import EFFECTS
from rths.diagnose.nominal import NominalModel, load_nominal, parse_nominal
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
