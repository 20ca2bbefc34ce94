"""The vRTHS benchmark (Silva et al. 2020) reproduced: its Simulink model, its plant draws, and
every compensator compared on its four partitioning cases.

* :mod:`~rths.experiments.vrths.draws` -- the nominal plant and F1's perturbed draws;
* :mod:`~rths.experiments.vrths.simulink` -- a block-for-block reimplementation of the
  benchmark's Simulink model with its sample controller (the oracle);
* :mod:`~rths.experiments.vrths.rig` -- the benchmark assembled from the project's frame,
  actuator, emulated lab and loop;
* :mod:`~rths.experiments.vrths.compare`, :mod:`~rths.experiments.vrths.tables` -- the
  comparison behind ``rths compare`` and its tables and figure.

The scoring itself (F4's J1-J9) is :mod:`rths.metrics.vrths`; the frame is :mod:`plants.frame`;
the sample controller is :mod:`controllers.baselines.pi_lead`.  Facts and sources:
docs/vrths_benchmark.md.
"""
