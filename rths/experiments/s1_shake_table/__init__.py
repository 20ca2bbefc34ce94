"""S1's shaking-table experiment (Pietrosanti, De Angelis, Giaralis): stepped-sine sweeps up and
down of the TMDI-equipped SDOF (:mod:`~.sweep`, configured by :mod:`~.config`, driven by
:mod:`~.shake_table`), FRFs per S1 Eq.7 (:mod:`~.frf`) and the figures (:mod:`~.report`).

May import: anything in the framework; nothing imports it but :mod:`rths.commands`.
"""
