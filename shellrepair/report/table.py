"""Reports: the hole table of a scan, and the paper's Table 1 for a repair.

Both come as a dict ready for JSON (``json.dumps``) and as text a person
reads. The interpolation rate is the paper's (Table 1):

    rate = (holes_before − holes_after) / holes_before × 100 %

(156 before, 54 after, 65.4 % on the paper's statue scan).

What is left is stated, not hidden: boundary chains that do not close
(they run into a non-manifold edge or a badly wound face) count among the
openings not filled, and the rate is withheld (``None``, with
``rate_withheld`` saying why) while the output keeps a non-manifold edge or
a boundary edge outside the loops left open as borders, so a table never
shows 100 % for an output that is not closed. The repair measures
``boundary_edges_after`` and ``nonmanifold_edges_after`` on the output's
own faces (coincident vertices joined, as :func:`shellrepair.mesh.io.read_mesh`
joins them).
"""

from __future__ import annotations

import numpy as np

__all__ = ["holes_dict", "holes_table", "interpolation_rate", "repaired", "short_reason", "status_counts", "table1_dict",
           "table1_text"]

STATUSES = ("filled", "skipped", "failed")


def interpolation_rate(before, after):
    """The paper's interpolation rate in percent; None when there was nothing to fill.

    Parameters
    ----------
    before, after : int
        Holes before and after the repair.

    Returns
    -------
    rate : float or None

    Examples
    --------
    >>> round(interpolation_rate(156, 54), 1)
    65.4
    """
    before, after = int(before), int(after)
    if before <= 0:
        return None
    return 100.0 * (before - after) / before


def loops_phrase(ids):
    """``[3, 7, 14]`` -> ``"3, 7 and 14"``."""
    ids = [str(i) for i in ids]
    return ids[0] if len(ids) == 1 else ", ".join(ids[:-1]) + " and " + ids[-1]


def _r(x, nd=6):
    return float(np.round(float(x), nd)) if x is not None else None


def holes_dict(scan, *, path=None, n_vertices=None, n_faces=None, notes=()):
    """The hole scan of a mesh as a JSON-ready dict.

    Parameters
    ----------
    scan : HoleScan
    path : str, optional
    n_vertices, n_faces : int, optional
    notes : list of str
        What loading changed.

    Returns
    -------
    d : dict
        ``file, vertices, faces, components, holes, borders, open_chains,
        boundary_edges, nonmanifold_edges, euler, notes, loops: [...]``.
    """
    loops = []
    for lp in scan.loops:
        d = lp.as_dict()
        for k in ("perimeter", "mean_edge", "area", "diameter", "planarity", "piece_area", "inside_fraction"):
            d[k] = _r(d[k], 9 if k != "inside_fraction" else 4)
        if d.get("center") is not None:
            d["center"] = [_r(x, 9) for x in d["center"]]
        loops.append(d)
    return {
        "file": None if path is None else str(path),
        "vertices": None if n_vertices is None else int(n_vertices),
        "faces": None if n_faces is None else int(n_faces),
        "components": int(scan.n_components),
        "holes": len(scan.holes),
        "borders": len(scan.borders),
        "open_chains": len(scan.open_chains),
        "boundary_edges": int(scan.n_boundary_edges),
        "nonmanifold_edges": int(scan.n_nonmanifold_edges),
        "euler": int(scan.euler),
        "notes": list(notes),
        "loops": loops,
    }


def _centre(c):
    """A loop's centre for the table (the scan's units), or '–'."""
    return "–" if c is None else "(" + ", ".join(f"{x:.7g}" for x in c) + ")"


def holes_table(d, *, limit=40):
    """A table a person reads, from :func:`holes_dict`'s output."""
    lines = [f"{d['file']}: {d['vertices']} vertices, {d['faces']} faces, {d['components']} components",
             f"  {d['holes']} holes, {d['borders']} borders, {d['open_chains']} open boundary chains, "
             f"{d['nonmanifold_edges']} non-manifold edges"]
    for n in d.get("notes", []):
        lines.append(f"  note: {n}")
    if d["loops"]:
        lines.append(f"  {'id':>4} {'kind':<6} {'edges':>6} {'perimeter':>11} {'mean edge':>10} "
                     f"{'area':>11} {'diameter':>10} {'planar':>7} {'comp':>4}  {'centre (x, y, z)':<38}  reason")
        rows = sorted(d["loops"], key=lambda x: -x["edges"])
        for lp in rows[:limit]:
            lines.append(f"  {lp['id']:>4} {lp['kind']:<6} {lp['edges']:>6} {lp['perimeter']:>11.5g} "
                         f"{lp['mean_edge']:>10.4g} {lp['area']:>11.5g} {lp['diameter']:>10.4g} "
                         f"{lp['planarity']:>7.3f} {lp['component']:>4}  {_centre(lp.get('center')):<38}  "
                         f"{lp['reason']}")
        if len(rows) > limit:
            lines.append(f"  ... {len(rows) - limit} smaller loops (see --json)")
    return "\n".join(lines)


def table1_dict(holes_before, results, *, path=None, seconds=None, method=None, order=None,
                borders=0, open_chains=(), extra=None):
    """The paper's Table 1 for a repair, with a status per hole.

    Parameters
    ----------
    holes_before : int
        Hole-class loops found before the repair.
    results : list of dict
        One per hole: at least ``id, edges, status`` (filled / skipped /
        failed) and ``reason``; repairs add ``new_vertices, new_faces,
        seconds``.
    path : str, optional
    seconds : float, optional
    method : str, optional
    order : int, optional
    borders : int
        Loops left open as borders (not counted as holes).
    open_chains : list of (k,) int64 arrays
        Boundary chains that do not close (never filled); they count as
        openings left in the rate.
    extra : dict, optional
        More top-level fields. With ``boundary_edges_after``,
        ``nonmanifold_edges_after`` and ``border_edges_after`` (edges of the
        loops left open as borders) the rate is withheld while the output
        is not closed outside its borders.

    Returns
    -------
    d : dict
        ``holes_before, holes_after, open_chains, interpolation_rate,
        rate_withheld, filled, skipped, failed, holes: [...]`` and the
        fields given.
    """
    filled = sum(1 for r in results if r["status"] == "filled")
    after = int(holes_before) - filled
    n_chains = len(open_chains)
    rate = interpolation_rate(int(holes_before) + n_chains, after + n_chains)
    withheld = None
    if extra:
        nm = int(extra.get("nonmanifold_edges_after") or 0)
        loose = int(extra.get("boundary_edges_after") or 0) - int(extra.get("border_edges_after") or 0)
        if rate is not None and rate >= 100.0 and (nm > 0 or loose > 0):
            withheld = (f"the output still has {nm} non-manifold edges and {max(loose, 0)} boundary edges "
                        "outside the borders left open")
            rate = None
    d = {
        "file": None if path is None else str(path),
        "method": method,
        "order": order,
        "holes_before": int(holes_before),
        "holes_after": after,
        "open_chains": n_chains,
        "interpolation_rate": None if rate is None else round(rate, 2),
        "rate_withheld": withheld,
        "filled": filled,
        "skipped": sum(1 for r in results if r["status"] == "skipped"),
        "failed": sum(1 for r in results if r["status"] == "failed"),
        "borders": int(borders),
        "seconds": None if seconds is None else round(float(seconds), 4),
        "holes": list(results),
    }
    if extra:
        d.update(extra)
    return d


def table1_text(d, *, limit=30):
    """Table 1 as a person reads it, from :func:`table1_dict`'s output."""
    rate = "n/a" if d["interpolation_rate"] is None else f"{d['interpolation_rate']:.1f}"
    chains = int(d.get("open_chains") or 0)
    lines = [f"{d['file'] or ''}",
             "               before   after   interpolation rate [%]",
             f"  holes      {d['holes_before']:>8} {d['holes_after']:>7}   {rate:>10}",
             f"  filled {d['filled']}, skipped {d['skipped']}, failed {d['failed']}; "
             f"{d['borders']} borders left open"
             + (f"; {chains} boundary chains that do not close (counted as not filled)" if chains else "")
             + ("" if d.get("seconds") is None else f"; {d['seconds']:.2f} s")]
    if d.get("rate_withheld"):
        lines.append(f"  rate withheld: {d['rate_withheld']}")
    if d.get("boundary_edges_after") is not None:
        lines.append(f"  left in the output: {d['boundary_edges_after']} boundary edges "
                     f"({d.get('border_edges_after', 0)} of them in borders), "
                     f"{d.get('nonmanifold_edges_after', 0)} non-manifold edges")
    fixes = [(k, d.get(k)) for k in ("vertices_joined", "nonmanifold_edges_found", "folded_faces_dropped",
                                     "nonmanifold_edges_split",
                                     "nonmanifold_vertices_split", "vertices_added")]
    if any(v for _, v in fixes):
        lines.append("  topology: " + ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in fixes if v))
    kinds = _tally(_filled_by(h) for h in d["holes"] if h["status"] == "filled" and h.get("option"))
    if kinds:
        lines.append("  filled by: " + kinds)
    for b in d.get("bridges") or []:
        if b["chosen"] == "tube" or "hole" in b.get("kinds", ()):  # borders that stay open need no line
            lines.append(f"  loops {loops_phrase(b['loops'])}: {b.get('shape') or b['chosen']} ({b['reason']})")
    failures = _tally(h["failure"] for h in d["holes"] if h["status"] == "failed" and h.get("failure"))
    if failures:
        lines.append("  failed because: " + failures)
    open_rows = [h for h in d["holes"] if h["status"] != "filled"]
    if open_rows:
        lines.append("  left open:")
        for h in open_rows[:limit]:
            lines.append(f"    hole {h['id']:>4} ({h['edges']} edges): {h['status']}: {short_reason(h['reason'])}")
        if len(open_rows) > limit:
            lines.append(f"    ... {len(open_rows) - limit} more (see the JSON report)")
    return "\n".join(lines)


#: A left-open row's reason in the table is cut to about this many characters.
REASON_WIDTH = 240


def short_reason(reason, width=REASON_WIDTH):
    """A hole's reason as one line of the table: whole where it is short;
    else its first and last steps (the attempts are separated by "; "),
    each cut to its share of ``width``, with the number of steps between
    them. The JSON report keeps every step: a hole the last layer gave up
    on reads thousands of characters (a 4-edge gap of a ragged scan: 2174).

    Parameters
    ----------
    reason : str
    width : int

    Returns
    -------
    line : str
    """
    reason = " ".join(str(reason).split())
    if len(reason) <= width:
        return reason
    steps = _steps(reason)
    if len(steps) < 2:
        return reason[:width - 1] + "…"
    half = max(width // 2 - 30, 20)
    first, last = steps[0], steps[-1]
    cut = lambda t: t if len(t) <= half else t[:half - 1] + "…"
    between = len(steps) - 2
    middle = f" [{between} more steps: the JSON report]; " if between else " [the JSON report has it all]; "
    return cut(first) + ";" + middle + cut(last)


def _steps(reason):
    """``reason`` split at each "; " outside parentheses (a step's own
    account, in parentheses, may hold "; " of its own)."""
    out, depth, start = [], 0, 0
    for i, ch in enumerate(reason):
        depth = max(0, depth + (ch == "(") - (ch == ")"))
        if depth == 0 and reason.startswith("; ", i):
            out.append(reason[start:i])
            start = i + 2
    out.append(reason[start:])
    return out


def _tally(keys):
    """``"faired order 3 ×4, tube ×1"``: each key with its count, most
    first (equal counts in the order first seen); "" for none."""
    from collections import Counter

    return ", ".join(f"{k} ×{v}" for k, v in Counter(keys).most_common())


def _filled_by(row):
    """What filled a hole, from its row's ``kind`` and ``order`` ("faired
    order 3", "tube", "flat cap"); a report written before rows named their
    kind: the first words of its ``option``."""
    kind = row.get("kind")
    if not kind:
        return row["option"].split(",")[0].split(":")[0].split(" (")[0]
    return f"{kind} order {row['order']}" if kind == "faired" and row.get("order") else kind


def status_counts(summary):
    """``"3 ok, 1 partial, 0 failed"`` (partial: repaired, some holes not closed)."""
    part = summary.get("n_partial", 0)
    return (f"{summary.get('n_ok', 0)} ok, " + (f"{part} partial, " if part else "")
            + f"{summary.get('n_failed', 0)} failed")


def repaired(row):
    """Was the scan of this batch summary row repaired and written (status
    ``ok``, or ``partial``: some of its holes could not be closed)?"""
    return row["status"] in ("ok", "partial")
