"""Excitations applied to a structure: the shaking table's stepped sine (S1 §2.3,
:mod:`~.stepped_sine`).
"""
