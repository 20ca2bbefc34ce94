"""The compiled integrator of the S1 plants (numba; private): the flat arrays it works on
(:mod:`~.layout`), the constitutive laws (:mod:`~.laws`) and the fixed-step kernel with its
contact events (:mod:`~.kernel`)."""
