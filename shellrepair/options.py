"""The options of a repair, checked once.

:class:`RepairOptions` is what :func:`shellrepair.repair.repair_mesh`,
:func:`shellrepair.batch.repair_folder` and the command line share: one
frozen record, validated when it is made, whose messages name the option
(``jobs must be at least 1, got 0``), not a command-line flag.

>>> RepairOptions(order="auto", jobs=2).order
'auto'
>>> RepairOptions(smooth=-1)
Traceback (most recent call last):
...
shellrepair.errors.MeshError: smooth must be a whole number, 0 or more, got -1
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass

from shellrepair.errors import MeshError

__all__ = ["RepairOptions", "NAMED_ORDERS", "order_value"]

#: The orders given by name, not number: the flat triangulation and the order test's choice.
NAMED_ORDERS = ("flat", "auto")
_ORDERS = (1, 2, 3) + NAMED_ORDERS
_METHODS = ("fair", "seed")
_BRIDGES = ("auto", "never", "always")
_BASES = ("auto", "flat", "faired")


def _whole(x):
    return isinstance(x, numbers.Integral) and not isinstance(x, bool)


def order_value(o):
    """An order as the options keep it: ``"flat"`` and ``"auto"`` by name,
    a number as a plain int (``"2"`` or ``numpy.int64(2)`` -> ``2``).

    Parameters
    ----------
    o : int, str

    Returns
    -------
    int or str
    """
    return o if o in NAMED_ORDERS else int(o)


@dataclass(frozen=True)
class RepairOptions:
    """How holes are found and filled.

    Attributes
    ----------
    order : {1, 2, 3, "flat", "auto"}
        Fairing order: harmonic, bilaplacian, curvature-continuous;
        ``"flat"``: the rim's triangulation with no new vertex (a band's
        tube and a pants at order 1); ``"auto"`` (default) picks 1, 2 or
        3 per hole: the order whose
        fills of test holes of the hole's own size, cut into intact scan
        beside it, lie closest to the scan cut away; a tube's by test
        bands of its own kind (:mod:`shellrepair.fill.selftest`,
        :mod:`shellrepair.fill.probe`).
    smooth : int
        Non-shrinking smoothing passes of each patch after fairing (for
        ``method="seed"``: passes over the whole duplicate).
    max_hole : int or None
        Loops with more edges stay open (borders).
    fill_borders : bool
        Fill borders too.
    method : {"fair", "seed"}
        The faired shells, or the paper's simple shape model.
    jobs : int
        Processes building patches (and, where the holes fill in this
        process, more than one: a helper thread for ``order="auto"``'s order
        tests and order-3 patches); the output is the same for any value.
    bridge : {"auto", "never", "always"}
        Bands between two loops: tube or caps by energy, caps only, or any
        valid tube.
    closed : bool or None
        How each piece is read: None infers it from its normals, True reads
        every piece as part of a closed object, False as a single view.
    base : {"auto", "flat", "faired"}
        A planar opening of a scan whose walls stand across its plane (the
        unscanned underside of a figure that stood on a table, or a cut
        through the figure): ``"auto"`` (default) and ``"faired"``
        continue the walls into a faired fill (the order test's choice);
        ``"flat"`` caps every such opening flat (the object's real base is
        there: say so). Planar openings of CAD parts are capped flat in
        every case. (``"auto"`` capped a scan's opening flat where the
        walls turn into it until that rule was measured to lose:
        :data:`shellrepair.fill.patch.EDGE_ON_COS`.)
    leave_open : tuple of int
        Hole ids (as ``shellrepair holes`` lists them) left open on
        purpose: reported as skipped, "left open by request".
    order_for : dict of int -> {1, 2, 3, "auto"}
        A fairing order for single holes (by id), over ``order``; a band
        between two loops takes the order given for either of them.
    expect : dict of int -> (int or None, sequence of 3 floats or None)
        The loops a plan (:mod:`shellrepair.plan`) acted on, as it saw them
        (edges, centre): a scan whose loop of that id differs is refused.
    max_hole_size : (float, str) or None
        Loops wider than this (their rim's diameter), a length with its
        unit such as ``(20.0, "mm")``, are left open as borders, like
        ``max_hole`` in edges. The scan's own unit is ``unit``.
    unit : {"mm", "cm", "m"} or None
        The scan's length unit, for ``max_hole_size``; None infers it from
        the scan's size (:func:`shellrepair.mesh.units.infer_unit`) and the
        report says so.
    cap_flat : tuple of int
        Hole ids to cap on their own (never bridged to another loop) by the
        harmonic patch, order 1: flat where the rim is planar (a cut the
        user knows is flat), the least-area-like membrane otherwise.
    fill : tuple of int
        Loop ids (``shellrepair holes`` lists borders too) to fill although
        they are classed border (an open base, a scan's outer edge, a loop
        over ``max_hole``): filled as holes, reported as filled by request.
    """

    order: object = "auto"
    smooth: int = 0
    max_hole: int | None = None
    fill_borders: bool = False
    method: str = "fair"
    jobs: int = 1
    bridge: str = "auto"
    closed: bool | None = None
    base: str = "auto"
    leave_open: tuple = ()
    order_for: dict = dataclasses.field(default_factory=dict, hash=False)
    cap_flat: tuple = ()
    fill: tuple = ()
    max_hole_size: tuple | None = None
    unit: str | None = None
    expect: dict = dataclasses.field(default_factory=dict, hash=False)

    def __post_init__(self):
        if isinstance(self.order, bool) or self.order not in _ORDERS:
            raise MeshError(f"order must be 1, 2, 3, 'flat' or 'auto', got {self.order!r}")
        if not _whole(self.smooth) or self.smooth < 0:
            raise MeshError(f"smooth must be a whole number, 0 or more, got {self.smooth!r}")
        if self.max_hole is not None and (not _whole(self.max_hole) or self.max_hole < 1):
            raise MeshError(f"max_hole must be a whole number, at least 1, got {self.max_hole!r}")
        if not isinstance(self.fill_borders, bool):
            raise MeshError(f"fill_borders must be True or False, got {self.fill_borders!r}")
        if self.method not in _METHODS:
            raise MeshError(f"method must be 'fair' or 'seed', got {self.method!r}")
        if not _whole(self.jobs) or self.jobs < 1:
            raise MeshError(f"jobs must be a whole number, at least 1, got {self.jobs!r}")
        if self.bridge not in _BRIDGES:
            raise MeshError(f"bridge must be 'auto', 'never' or 'always', got {self.bridge!r}")
        if self.closed not in (None, True, False):
            raise MeshError(f"closed must be None, True or False, got {self.closed!r}")
        if self.base not in _BASES:
            raise MeshError(f"base must be 'auto', 'flat' or 'faired', got {self.base!r}")
        if self.max_hole_size is not None:
            from shellrepair.mesh.units import UNITS_UM

            size = self.max_hole_size
            ok = isinstance(size, (tuple, list)) and len(size) == 2 and size[1] in UNITS_UM
            try:
                value = float(size[0]) if ok and not isinstance(size[0], bool) else float("nan")
            except (TypeError, ValueError):
                value = float("nan")
            if not (ok and math.isfinite(value) and value > 0):
                raise MeshError(f"max_hole_size must be a positive length and its unit, such as (20, 'mm'), "
                                f"got {size!r}")
            object.__setattr__(self, "max_hole_size", (value, str(size[1])))
        if self.unit is not None and self.unit not in ("mm", "cm", "m"):
            raise MeshError(f"unit must be 'mm', 'cm' or 'm', got {self.unit!r}")
        for name in ("leave_open", "cap_flat", "fill"):
            given = getattr(self, name)
            ids = tuple(given) if isinstance(given, (list, tuple, set, frozenset)) else None
            if ids is None or not all(_whole(i) and i >= 0 for i in ids):
                raise MeshError(f"{name} must be loop ids (whole numbers, 0 or more), got {given!r}")
            object.__setattr__(self, name, tuple(sorted({int(i) for i in ids})))
        if not isinstance(self.order_for, dict) or not all(
                _whole(i) and i >= 0 and not isinstance(o, bool) and o in _ORDERS for i, o in self.order_for.items()):
            raise MeshError(f"order_for must map hole ids to 1, 2, 3, 'flat' or 'auto', got {self.order_for!r}")
        object.__setattr__(self, "order_for", {int(i): order_value(o) for i, o in sorted(self.order_for.items())})
        for a, b, what in (("leave_open", "order_for", "left open and given an order"),
                           ("leave_open", "cap_flat", "left open and capped flat"),
                           ("leave_open", "fill", "left open and filled"),
                           ("cap_flat", "order_for", "capped flat and given an order")):
            both = set(getattr(self, a)) & set(getattr(self, b))
            if both:
                raise MeshError(f"hole {min(both)} is both {what}")
        # NumPy integers in, plain ints kept (reports are JSON)
        for name in ("smooth", "jobs") + (("max_hole",) if self.max_hole is not None else ()) + \
                (("order",) if self.order not in NAMED_ORDERS else ()):
            object.__setattr__(self, name, int(getattr(self, name)))

    def replace(self, **changes):
        """A copy with some options changed (validated again)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise MeshError(f"unknown repair option(s): {', '.join(sorted(unknown))}")
        return dataclasses.replace(self, **changes)

    def as_dict(self):
        """The options as a plain dict (for reports and summaries)."""
        return dataclasses.asdict(self)

    @classmethod
    def make(cls, options=None, **changes):
        """``options`` (or the defaults) with ``changes`` applied."""
        base = cls() if options is None else options
        if not isinstance(base, cls):
            raise MeshError(f"options must be a RepairOptions, got {type(base).__name__}")
        return base.replace(**changes) if changes else base
