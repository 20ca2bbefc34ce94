"""The stay cable (S0 §5): taut-string finite elements with a node at the damper
(:mod:`~.fe`), Newmark average acceleration (:mod:`~.newmark`), the nominal interface device
condensed into the solve (:mod:`~.device`), the :class:`~plants.cable.model.Cable` substructure
(:mod:`~.model`), its properties and S0 Eq.22-23 (:mod:`~.properties`), and the exact cable--damper
frequency equation (:mod:`~.frequency_equation`).

Modelling choices (with the evidence)
-------------------------------------
* **Mass matrix: the average of the consistent and lumped matrices**, element
  ``m h/12 [[5,1],[1,5]]``.  On a uniform mesh its frequencies are fourth-order accurate (the
  consistent matrix overestimates by ``(kh)^2/24``, the lumped one underestimates by the same).
  Measured against the exact frequency equation (:mod:`plants.cable.frequency_equation`), viscous
  damper at ``x_d = 0.02``, ``kappa = 1``, mode 1, relative error of the damping ratio for N =
  50/100/200/400 elements: consistent 3.4e-4/8.5e-5/2.1e-5/5.3e-6, lumped
  -3.3e-4/-8.1e-5/-2.0e-5/-5.1e-6, average 7.0e-6/1.8e-6/4.5e-7/1.1e-7.  For the IMD optimum of mode
  3 the error is dominated by the sensitivity of the two nearly coalescent roots and all three
  converge as 1/N^2 with the same constant (consistent 7.6e-4, lumped 8.8e-4, average 8.1e-4 at N =
  400, worst root), so the average matrix costs nothing there and gains 50x elsewhere; it stays
  tridiagonal. Reproduce with ``python tools/bench_cable.py --mass-study``.
* **Intrinsic damping: Rayleigh** ``C = a0 M + a1 K`` anchored at two string modes (default
  modes 1 and 3, 0.1 %, S0 §1).  It keeps ``C`` tridiagonal and the damping classical, unlike
  dense modal damping; pure stiffness-proportional damping would triple the ratio of mode 3 (the
  seed test's mode) when mode 1 has 0.1 %.  Above the upper anchor the ratio grows like
  ``a1 omega/2``, which quietly damps the spurious high FE modes a stepped device force excites.
* **Coupling and time alignment**: ``step(F_k)`` advances from ``t_k`` to ``t_{k+1}``; the device
  restoring force ``F_k`` measured at ``t_k`` is applied as the interface force *at* ``t_{k+1}``
  (the standard one-step lag of RTHS), and the cable receives ``-F_k`` (sign convention of
  :mod:`plants.base`).  The distributed load (S0 Eq.22) is evaluated exactly at ``t_{k+1}``.
* **Nominal interface device** (:class:`InterfaceDevice`): a rigid part (inertance ``m_r``
  [kg], dashpot ``c_r`` [N s/m], simplified S0 Eq.1, and a grounded spring ``k_r`` [N/m])
  added to ``M``, ``C`` and ``K``, and an optional series branch (spring ``k_s`` [N/m] to a
  flywheel ``m_s`` [kg] with dashpot ``c_s`` [N s/m] to ground, S0 Eq.12) whose flywheel DOF is
  condensed into the damper node's row of the Newmark system, which stays tridiagonal
  (:mod:`plants.cable.device`).  Both are integrated
  implicitly; ``device_force`` is the device's restoring force.  Why: in RTHS, feeding the
  measured force of a stiff or heavy specimen back explicitly (one step late, through an
  actuator with residual delay ``tau``) into a flexible FE cable is unstable -- a delayed
  stiffness acts as negative damping ``k tau`` and a string's driving-point impedance is only
  ``2 sqrt(T m)``.  So the cable carries a nominal model of the device and the loop feeds back
  only the (filtered) correction ``force_scale F - device_force`` (:mod:`rths.runtime.loop`).  For
  the S0 Type II IMD the nominal device needs the series stiffness, otherwise the correction is
  large above its 13.8 Hz self-vibration and the loop diverges.  The same device serves the fully
  numerical "mock" RTHS and the eigen-analysis (:mod:`plants.cable.frequency_equation`).
* **Mesh rule** with a series branch: elements shorter than ``h_max = 4 T/k_s``
  (:func:`max_element_size`, :func:`elements_for`), so that the damper node's local frequency on
  the device spring lies in the FE string's passband and what is excited there radiates into the
  string (details and limits in :mod:`plants.cable.device`); not enforced.
"""

from plants.cable.model import (
    Cable,
    CableProperties,
    DistributedLoad,
    FEMatrices,
    InterfaceDevice,
    PointDamper,
    RayleighDamping,
    elements_for,
    fe_matrices,
    max_element_size,
    normalised_damper,
    normalised_stiffness,
    physical_damper,
    physical_stiffness,
)

__all__ = [
    "Cable",
    "CableProperties",
    "DistributedLoad",
    "FEMatrices",
    "InterfaceDevice",
    "PointDamper",
    "RayleighDamping",
    "elements_for",
    "fe_matrices",
    "max_element_size",
    "normalised_damper",
    "normalised_stiffness",
    "physical_damper",
    "physical_stiffness",
]
