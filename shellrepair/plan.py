"""A repair plan: what to do with each hole, as a file a team can edit and keep.

``shellrepair repair SCAN --plan plan.json`` reads the per-hole requests of
:class:`shellrepair.options.RepairOptions` (``leave_open``, ``cap_flat``,
``fill``, ``order_for``) from a JSON file, in either of two forms:

* the requests themselves::

      {"leave_open": [3], "cap_flat": [4], "fill": [0], "order_for": {"5": 1}}

* the output of ``shellrepair holes SCAN --json`` with an ``"action"``
  added to the loops to act on (``"leave open"``, ``"cap flat"``,
  ``"fill"``, ``"order 1"`` .. ``"order 3"``, ``"order auto"``; a loop
  without one, or with ``""``, is left to the repair). Each such loop's
  ``edges`` and ``center`` are kept with the request, and the repair
  refuses the plan if the scan's loop of that id differs (a plan made for
  another scan, or with other detection options, names other loops).

Both forms may be combined in one file; requests on the command line are
added to the plan's. Anything else in the file is one error naming it.
"""

from __future__ import annotations

import json
from pathlib import Path

from shellrepair.errors import MeshError
from shellrepair.options import order_value

__all__ = ["read_plan", "ACTIONS"]

#: The actions a loop of ``holes --json`` may be given, and the request each makes.
ACTIONS = ("leave open", "cap flat", "fill", "order 1", "order 2", "order 3", "order flat", "order auto")
_LISTS = ("leave_open", "cap_flat", "fill")


def read_plan(path):
    """The requests of a plan file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    requests : dict
        ``leave_open``, ``cap_flat``, ``fill`` (lists of ids), ``order_for``
        (id -> 1, 2, 3 or ``"auto"``) and ``expect`` (id -> (edges, centre
        or None): the loops as the plan saw them).

    Raises
    ------
    MeshError
        When the file cannot be read or is not a plan (one line naming the
        file and what is wrong).
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise MeshError(f"cannot read the plan: {exc.strerror or exc}", path) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MeshError(f"the plan is not JSON: {exc}", path) from None
    if not isinstance(data, dict):
        raise MeshError("the plan must be a JSON object", path)
    out = {k: [] for k in _LISTS}
    out.update(order_for={}, expect={})
    known = set(_LISTS) | {"order_for", "loops"}
    from_holes = {"file", "vertices", "faces", "components", "holes", "borders", "open_chains",
                  "boundary_edges", "nonmanifold_edges", "euler", "notes"}     # holes --json's other keys
    extra = sorted(set(data) - known - from_holes)
    if extra:
        raise MeshError(f"the plan has keys no plan takes: {', '.join(extra)} "
                        f"(it takes {', '.join(sorted(known))})", path)
    for key in _LISTS:
        ids = data.get(key, [])
        if not isinstance(ids, list) or not all(_is_id(i) for i in ids):
            raise MeshError(f"the plan's {key!r} must be a list of loop ids, got {ids!r}", path)
        out[key] += [int(i) for i in ids]
    orders = data.get("order_for", {})
    if not isinstance(orders, dict):
        raise MeshError(f"the plan's 'order_for' must map loop ids to orders, got {orders!r}", path)
    for k, o in orders.items():
        if not (str(k).isdigit() and (o in (1, 2, 3, "auto")) and not isinstance(o, bool)):
            raise MeshError(f"the plan's 'order_for' maps {k!r} to {o!r}: ids to 1, 2, 3 or 'auto'", path)
        out["order_for"][int(k)] = o
    loops = data.get("loops", [])
    if not isinstance(loops, list):
        raise MeshError("the plan's 'loops' must be a list (as `shellrepair holes --json` prints it)", path)
    for lp in loops:
        action = lp.get("action", "") if isinstance(lp, dict) else None
        if action in ("", None) and isinstance(lp, dict):
            continue
        if not isinstance(lp, dict) or not _is_id(lp.get("id")) or action not in ACTIONS:
            raise MeshError(f"a loop of the plan must have an id and an action ({', '.join(ACTIONS)}), "
                            f"got {lp!r}", path)
        i = int(lp["id"])
        if action.startswith("order "):
            o = action.split()[1]
            out["order_for"][i] = order_value(o)
        else:
            out[action.replace(" ", "_")].append(i)
        edges, center = lp.get("edges"), lp.get("center")
        if not (edges is None or _is_id(edges)) or not (center is None or (
                isinstance(center, list) and len(center) == 3
                and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in center))):
            raise MeshError(f"loop {i} of the plan: 'edges' must be a count and 'center' three numbers, "
                            f"got {edges!r} and {center!r}", path)
        out["expect"][i] = (edges, None if center is None else [float(x) for x in center])
    return out


def _is_id(i):
    return isinstance(i, int) and not isinstance(i, bool) and i >= 0
