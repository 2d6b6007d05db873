"""The microfacet model's guards, shared by the NumPy functions
(:mod:`.microfacet`, where they are documented to users) and the compiled
kernels (:mod:`.common_kernels` and the ``*_kernels`` modules beside each model), so
that neither imports the other."""

import numpy as np

#: Smallest Beckmann roughness (RMS slope, dimensionless).  ``m -> 0`` is a
#: mirror whose D is a Dirac delta; below this value m is clamped.  At
#: m = 1e-3 the lobe is ~0.06 degrees wide, far below a pixel of any render
#: this package makes.
M_MIN = 1e-3

#: Cosines at or below this (dimensionless) count as "on the horizon": the
#: BRDF and the Beckmann D return 0 there instead of evaluating
#: exp(-tan^2/m^2) / cos^4, whose cos^4 underflows.
COS_EPS = 1e-12

#: Floor for denominators that are mathematically positive.
_TINY = np.finfo(np.float64).tiny

#: Floor (dimensionless) of the cosines n.i and n.o in the denominator
#: 4 (n.i)(n.o) of eq 8: cos(89.5 deg).  Without it a mirror pair of
#: directions both grazing the horizon gives f ~ D / (4 cos^2), 1e6-1e10
#: for the presets' roughness.  Flooring a denominator can only lower f, so
#: the directional albedo stays below its unfloored value (<= 1) and
#: ``f (n.i) <= F D(n.h) / (4 max(n.o, MU_FLOOR)) <= 1 / (4 pi m^2 MU_FLOOR)``.
MU_FLOOR = float(np.cos(np.radians(89.5)))
