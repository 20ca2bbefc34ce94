"""truthgen - independent truth-suite generator for sim-to-real gap diagnosis.

Run::

    python tools/truthgen --out DIR --cases N --seed S [--rates 1000,1024,2048,4096]
                          [--max-duration 40] [--jobs 1]

Writes ``DIR/case_000/ ... DIR/case_NNN/`` (each: ``rec_1.csv`` ... ``rec_R.csv``
and ``NOMINAL.toml``, nothing else), ``DIR/labels.json`` (the answers) and
``DIR/generator.json`` (arguments).  Deterministic for a given seed and
arguments (``--jobs`` does not change the output).  Progress on stderr; a bad
argument prints one line and exits with status 2.  Written from scratch with
numpy/scipy only; it imports nothing from the rths project.

Physics (``plant.py``)
----------------------
Servo-hydraulic actuator: 2nd-order servo valve (60-200 Hz, damping 0.5-0.9,
flow linear in spool position, load-pressure flow nonlinearity not modelled),
oil-column compressibility (load pressure, bulk modulus 0.7-1.4 GPa, leakage),
piston mass and seal damping, a controller board with displacement P loop and
delta-P stabilisation, tuned for a gain margin of 2-3.5 with the nominal
specimen installed, plus a 0.1-1 ms board latency.  The closed loop
command->displacement is 5th order with 8-30 ms low-frequency lag.  The
load-cell force (specimen reaction) loads the piston (control-structure
interaction).  Specimen: ball-screw inertial mass damper, inertance 200-5000 kg
+ 3-30 kg rod, viscous damping (0 or up to ~ the inertial impedance at 2 Hz),
optional 0.5-3 Hz parallel spring.  Effects (see ``design.py`` for ranges):
internal_stiffness (series spring || series damper between rod and flywheel),
backlash (clearance between load cell and rod, Kelvin-Voigt contact that only
pushes), coulomb_friction (elasto-plastic / Maxwell-slip presliding spring
saturating at the friction level, on the flywheel), amplitude_damping (extra
damping c1/(A + c2) on the flywheel, A = sqrt(2 x two-stage 0.3 s low-pass of
x^2), the running amplitude of the flywheel displacement), actuator_delay
(extra command transport delay), rate_limit (servo-amplifier current
saturation: valve opening, hence flow, limited to velocity_limit x area; the
label is the no-load speed).

Integration (``integrator.py``): the plant is piecewise affine; each mode is
propagated exactly (matrix exponential, zero-order-hold inputs) at an internal
step of Ts/M (>= 4096 Hz, finer for stiff contacts); contact, stick-slip and
saturation events are located to 2**-24 of a step.  The recorded channels pass
through an analog 4-pole Bessel anti-alias filter (cutoff 0.2-0.3 fs) that is
part of the continuous-time state and are sampled at t_k (no digital
decimation needed).

Conventions (``daq.py``)
------------------------
CSV header ``time,command,measured,force`` (s, m, m, N), uniform sampling at
1000/1024/2048/4096 Hz.  Row k: the command applied by the zero-order-hold DAC
over [t_k, t_k+1), and the displacement/force ADC samples at t_k.  16-bit DAC
and ADCs; displacement range per case (2-250 mm), force range auto-set per
record (1/2/2.5/5 x 10^n N >= 1.1 x peak); white noise 0.3-3 um and 0.3-5 N;
offsets up to 20 um and 10 N per record.

NOMINAL.toml: the exact linearisation of this actuator with the nominal
specimen (no effects) -- TF measured/command in descending powers of s,
delay = board latency + anti-alias group delay -- and the nominal specimen
(inertance = flywheel + rod), then mis-calibrated: gain, pole frequencies,
pole damping, inertance, damping, stiffness each by up to +/-10 %, delay by up
to +/-0.8 sample.  These are calibration errors, never labelled as effects.
friction is always 0.

Cases (``design.py``, ``generate.py``): 30 % (rounded up) carry two effects,
singles cycle through none + the six classes.  3-4 records of 10-40 s from the
families sine, stepped_sine, sweep, random, earthquake (``excitation.py``),
amplitudes set from the nominal model to 1-40 % of the actuator force with
stroke and speed budgets.  Each effect is simulated with and without it (the
other effect kept); labels carry per-record NRMSE on both channels and the SNR
(difference rms / channel noise rms) on the affected channel (``measured`` for
actuator effects, ``force`` for specimen effects).  An effect needs SNR >= 3 on
at least two records; otherwise its parameters are redrawn (at most 5 draws in
all), and if still too weak it is kept and flagged ``weak`` -- no case is ever
discarded.  Backlash cases also carry ``chaos_sensitivity_nrmse``: the force
NRMSE caused by changing the gap by 1 ppm (large = practically chaotic).
rate_limit is a flow limit (servo-amplifier current clip, which also clips the
delta-P stabilisation): with an inertial load the oil column rings at reversals,
so peak speed can exceed the label, in a 24-case suite by up to 2.8x
(``record_peak_speed_over_limit``); the speed plateau sits at the label.

Cost: 1.7-25 s CPU per case (median ~8 s) at full record lengths; a suite of
24 cases is ~190 MB of CSV.  ``--max-duration 3`` makes small test suites run
in a few seconds.

labels.json: ``{case: {effects: [{effect, channel, params, derived, strength,
...}], rate, records: [{file, excitation, ...}], noise,
nominal_miscalibration, true_nominal, nominal_written, actuator, specimen,
aa_filter, integration, references}}``; effects ordered strongest first; a
no-effect case has ``[{"effect": "none", "channel": null, "params": {}}]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from truthgen.cli import main
else:
    from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
