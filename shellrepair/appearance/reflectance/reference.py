"""The NumPy versions of the compiled reflectance functions: the kernels' oracles.

Each function here takes the arguments of the function of the same name in
:mod:`shellrepair.appearance.reflectance` and computes the same thing with NumPy
arrays only (no Numba).  It is the path that public function takes when the
compiled kernels are off (``SHELLREPAIR_NO_NUMBA=1``, i.e.
:data:`shellrepair.compiled.ENABLED` False; Numba missing) or for an
argument layout the kernels do not take, so two promises hold:

- with the kernels off, the public function returns this function's array
  bit for bit;
- with the kernels on, the two agree within ``1e-12`` relative (plus
  ``1e-250`` absolute: the kernels flush subnormals to zero),
  tests/test_reflectance_kernels.py.

They are several times slower than the kernels (``python
eval/bench_shading.py`` prints by how much); use them to check a kernel,
or to read the model's arithmetic as array expressions.  Each is defined
beside the function it mirrors (``microfacet``, ``albedo``, ``km``,
``dipole``, ``layered``) and only gathered here.  The shader's NumPy
version is :meth:`shellrepair.appearance.shader.MaterialShader.evaluate_numpy`.
"""

from __future__ import annotations

from shellrepair.appearance.reflectance.albedo import _diffuse_transmittance_np as diffuse_transmittance
from shellrepair.appearance.reflectance.albedo import _internal_reflectance_np as internal_reflectance
from shellrepair.appearance.reflectance.albedo import _mean_transmittance_np as mean_transmittance
from shellrepair.appearance.reflectance.dipole import _dipole_profile_np as dipole_profile
from shellrepair.appearance.reflectance.dipole import _dipole_rd_np as dipole_rd
from shellrepair.appearance.reflectance.dipole import _dipole_tail_fraction_np as dipole_tail_fraction
from shellrepair.appearance.reflectance.km import _km_r_inf_np as km_r_inf
from shellrepair.appearance.reflectance.km import _km_reflectance_np as km_reflectance
from shellrepair.appearance.reflectance.layered import _layered_diffuse_np as layered_diffuse
from shellrepair.appearance.reflectance.layered import _local_brdf_np as local_brdf
from shellrepair.appearance.reflectance.microfacet import _beckmann_D_np as beckmann_D
from shellrepair.appearance.reflectance.microfacet import _fresnel_conductor_np as fresnel_conductor
from shellrepair.appearance.reflectance.microfacet import _fresnel_dielectric_np as fresnel_dielectric
from shellrepair.appearance.reflectance.microfacet import _torrance_sparrow_conductor_np as torrance_sparrow_conductor
from shellrepair.appearance.reflectance.microfacet import _torrance_sparrow_np as torrance_sparrow
from shellrepair.appearance.reflectance.microfacet import _v_cavity_G_np as v_cavity_G

__all__ = ["beckmann_D", "v_cavity_G", "fresnel_dielectric", "fresnel_conductor", "torrance_sparrow",
           "torrance_sparrow_conductor", "diffuse_transmittance", "mean_transmittance", "internal_reflectance",
           "layered_diffuse", "local_brdf", "km_r_inf", "km_reflectance", "dipole_rd", "dipole_tail_fraction",
           "dipole_profile"]
