"""The scan's length unit: given, or inferred from its size.

A mesh file carries no unit. Where a length is asked for in a unit (the
render's pixel footprint, ``--max-hole 20mm``), the scan's unit is the one
the user gives (``--unit``), else the one that makes the scan a plausibly
sized statue (:func:`infer_unit`), and the output says which.
"""

from __future__ import annotations

import numpy as np

__all__ = ["UNITS_UM", "STATUE_HEIGHT_M", "infer_unit", "parse_length", "in_scan_units"]


#: Length of one mesh unit in micrometres, by unit name.
UNITS_UM = {"mm": 1e3, "cm": 1e4, "m": 1e6}
#: Heights (metres) a statue scan plausibly has: a figurine to a life-size
#: statue.
STATUE_HEIGHT_M = (0.05, 3.0)
#: Order of preference when several units give a plausible height: scanners
#: and the formats they write mostly use millimetres.
_UNIT_PREFERENCE = ("mm", "m", "cm")


def infer_unit(V):
    """The length unit that makes a scan a plausibly sized statue.

    Parameters
    ----------
    V : (n,3) float array

    Returns
    -------
    unit : str
        ``"mm"``, ``"cm"`` or ``"m"``.
    reason : str
        One line saying why (the height it implies).

    Notes
    -----
    The height is the largest bounding-box extent (whatever the up axis).
    Among the units that put it in :data:`STATUE_HEIGHT_M` the first of
    mm, m, cm is taken (an extent of 50-300 fits both mm and cm: mm is the
    scanners' usual unit); if none does, the unit whose height is closest to
    the range (in ratio) is taken and the reason says so.

    Examples
    --------
    >>> infer_unit(np.array([[0, 0, 0], [0.06, 0.15, 0.05]]))[0]   # the Stanford bunny
    'm'
    >>> infer_unit(np.array([[0, 0, 0], [240.0, 360, 490]]))[0]   # a bust in mm
    'mm'
    """
    V = np.asarray(V, dtype=np.float64)
    ext = float(np.max(V.max(axis=0) - V.min(axis=0))) if len(V) else 0.0
    lo, hi = STATUE_HEIGHT_M
    heights = {u: ext * UNITS_UM[u] * 1e-6 for u in UNITS_UM}
    for u in _UNIT_PREFERENCE:
        if lo <= heights[u] <= hi:
            return u, ("inferred: the largest extent %.4g would be %.3g m tall in %s, a plausible "
                       "statue (%.2g-%.2g m)" % (ext, heights[u], u, lo, hi))

    def miss(u):
        hgt = max(heights[u], 1e-300)
        return max(np.log(lo / hgt), np.log(hgt / hi), 0.0)

    u = min(_UNIT_PREFERENCE, key=miss)
    return u, ("inferred: no unit makes the largest extent %.4g a %.2g-%.2g m statue; %s "
               "(%.3g m) is the closest" % (ext, lo, hi, u, heights[u]))


def parse_length(text):
    """A length with its unit, ``"20mm"``, ``"2.5 cm"``, ``"0.02m"``: (value, unit).

    Parameters
    ----------
    text : str

    Returns
    -------
    value : float
        Positive and finite.
    unit : str
        One of :data:`UNITS_UM`.

    Raises
    ------
    ValueError
        When ``text`` is not a positive number followed by mm, cm or m.

    Examples
    --------
    >>> parse_length("20mm")
    (20.0, 'mm')
    >>> parse_length(" 1.5 cm ")
    (1.5, 'cm')
    """
    t = str(text).strip().lower()
    for unit in sorted(UNITS_UM, key=len, reverse=True):   # "mm" before "m"
        if t.endswith(unit):
            try:
                value = float(t[:-len(unit)].strip())
            except ValueError:
                break
            if np.isfinite(value) and value > 0:
                return value, unit
            break
    raise ValueError(f"expected a positive length with its unit (mm, cm or m), such as 20mm, not {text!r}")


def in_scan_units(length, unit, V):
    """A length with its unit, in the units of the scan ``V``.

    Parameters
    ----------
    length : (float, str) or None
        Such as ``(20.0, "mm")`` (:func:`parse_length`).
    unit : str or None
        The scan's unit; None infers it (:func:`infer_unit`).
    V : (n,3) float array

    Returns
    -------
    value : float or None
        None when ``length`` is None.
    label : str
        The length as given, and in the scan's unit where that differs
        (``"2 cm = 20 mm"``).
    how : str
        The scan's unit and why (``"mm (given)"``).
    """
    if length is None:
        return None, "", ""
    value, given = length
    name, why = (unit, "given") if unit else infer_unit(V)
    scaled = value * UNITS_UM[given] / UNITS_UM[name]
    label = f"{value:g} {given}" + (f" = {scaled:g} {name}" if name != given else "")
    return scaled, label, f"{name} ({why})"
