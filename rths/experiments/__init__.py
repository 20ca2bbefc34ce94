"""Experiments of one paper each, built on the framework (never imported by it).

:mod:`~rths.experiments.s1_shake_table`: S1's shaking-table campaign (stepped-sine sweeps, FRFs).
"""
