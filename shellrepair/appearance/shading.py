"""The reflectance model under its historical name (a façade).

Everything lives in :mod:`shellrepair.appearance.reflectance` (microfacet, albedo,
Kubelka-Munk, dipole, layered); this module re-exports the same objects so
that ``from shellrepair.appearance.shading import rho_dt_table`` and ``sh.<name>`` keep
working.  The modules' names beyond the package's ``__all__`` that tests
and the benchmark read (``sh.rule_albedo``, ``sh.albedo_geometry``,
``sh.dipole_A``, ...) are found in the package's modules on attribute
access.
"""

from __future__ import annotations

from shellrepair.appearance.reflectance import *  # noqa: F401,F403  (the public names)
from shellrepair.appearance.reflectance import __all__  # noqa: F401
from shellrepair.appearance.reflectance import albedo as _albedo
from shellrepair.appearance.reflectance import dipole as _dipole
from shellrepair.appearance.reflectance import km as _km
from shellrepair.appearance.reflectance import layered as _layered
from shellrepair.appearance.reflectance import microfacet as _microfacet

_MODULES = (_microfacet, _albedo, _km, _dipole, _layered)


def __getattr__(name):
    """A name of a module (``rule_albedo``, ``SHIPPED_BITS``, ...) from the module that defines it."""
    for mod in _MODULES:
        if name in vars(mod):
            return getattr(mod, name)
    raise AttributeError("module %r has no attribute %r" % (__name__, name))
