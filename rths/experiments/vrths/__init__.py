"""The vRTHS benchmark (Silva et al. 2020) reproduced: its scoring, its Simulink model, and the
comparison of every compensator on its four partitioning cases.

* :mod:`~rths.metrics.vrths` -- J1-J9 exactly as ``F4_evaluation.m``;
* :mod:`~rths.experiments.vrths.draws` -- the nominal plant and F1's perturbed draws;
* :mod:`~rths.experiments.vrths.simulink` -- a block-for-block reimplementation of the
  benchmark's Simulink model with its sample controller (the oracle);
"""
