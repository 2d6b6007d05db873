"""The default's regret: its RMS over the best of our own forced choices.

``python eval/regret.py --seed 5000 --n 24`` builds stress cases
``0..n-1`` of the seed (:func:`eval.stress.stress_case`, families drawn as
the stress suite draws them) and fills each with our default
(``ours-auto``) and with one candidate kind forced on every hole
(``ours-o1``, ``ours-o2``, ``ours-o3``; and ``ours-flat``, the rim's
triangulation with no new vertex, shown beside them: not a candidate of
the default, so not in its regret), in this process, measuring each as
the stress suite does (:func:`eval.stress.measure`, RMS in per mille of
the truth's diagonal over the filled surface).

Per case, the regret is (default RMS + FLOOR) / (best forced RMS + FLOOR),
``FLOOR = 0.05`` per mille (below it the fills are all as good as the
scan's own sampling): 1 means the default picked as well as the best single
forced kind, above 1 it picked worse. Only outputs that closed every hole
classed ``hole`` are compared (a forced kind that left a hole open is not a
candidate that could have been chosen). Writes
``<out>/regret-seed<seed>.json`` and ``.md`` (per case, and the geometric
mean and maximum).

With ``--peers`` the other hole fillers run on the same cases (those
installed: ``pip install -e '.[bench]'``; eval/peers.py), screened Poisson
reconstruction kept where it covers the holes among them (``poisson``,
:func:`eval.peers.poisson_trimmed`), and each case
also gets the default's RMS over the best peer's that closed every hole
(same floor): issue 36 asks for a median of at most 0.7 and no case over
1.1.

The cost column is the default's fill seconds (the report's, imports and
kernel loading excluded) over the fastest forced order's on the same case
.
With ``--ragged S`` every rim gets a scanner's ragged fringe
(:func:`eval.stress.ragged_rims`: noise along the normal of ``S`` mean edge
lengths, half as much on the next ring; the truth stays the clean surface).
The stress families otherwise have rims as clean as the rest of the scan,
so a choice that ignores a rim's noise (a higher order carries it on into
the hole) is not seen failing without it.

Seeds below 1000 are for development; a constant of the choice is set on
them and reported on seeds of 1000 and over (the validation seeds), never
tuned there.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from eval import peers, stress  # noqa: E402

FORCED = ("ours-o1", "ours-o2", "ours-o3")
#: Forced kinds shown beside them that the default does not choose among.
SHOWN = ("ours-flat",)
DEFAULT = "ours-auto"
#: The peers of ``--peers`` (run where installed).
PEERS = ("cgal", "meshlib-nicely", "pymeshfix", "pymeshlab", "poisson")
#: Per mille of the diagonal added to both sides of the ratio.
FLOOR = 0.05


def run_case(case, tools=(DEFAULT,) + FORCED + SHOWN, log=print):
    """{tool: row} for one case (RMS, closure, fill seconds)."""
    facts = stress.input_facts(case)
    rows = {}
    for tool in tools:
        t0 = time.perf_counter()
        try:
            V, F, info = peers.run_tool(tool, case.V, case.F)
        except Exception as exc:  # a tool's failure is a row, not the end of the run
            rows[tool] = {"status": "error", "error": f"{type(exc).__name__}: {exc}"}
            log(f"  {tool:10s} error {exc}")
            continue
        m = stress.measure(case, facts, V, F)
        row = {"status": "ok", "seconds": round(float(info.get("seconds", time.perf_counter() - t0)), 4),
               "rms_permille": m.get("rms_permille"), "holes": int(facts["is_hole"].sum()),
               "holes_closed": m.get("holes_closed")}
        if "untold" in info:
            row["untold"], row["reported_holes"] = int(info["untold"]), int(info["reported_holes"])
        rows[tool] = row
        log(f"  {tool:10s} RMS {row['rms_permille']} ‰, {row['holes_closed']}/{row['holes']} closed, "
            f"{row['seconds']} s")
    return rows


def _ok(rows, t):
    r = rows.get(t)
    return (r is not None and r["status"] == "ok" and r["rms_permille"] is not None
            and r["holes_closed"] == r["holes"])


def over_peer(rows):
    """(the default's RMS over the best peer's, that peer) of one case, or
    (None, None) where no peer closed every hole or the default did not."""
    cands = {t: rows[t]["rms_permille"] for t in PEERS if _ok(rows, t)}
    if not cands or not _ok(rows, DEFAULT):
        return None, None
    best = min(cands, key=cands.get)
    return (rows[DEFAULT]["rms_permille"] + FLOOR) / (cands[best] + FLOOR), best


def regret(rows):
    """(regret, best forced tool) of one case, or (None, None)."""
    cands = {t: rows[t]["rms_permille"] for t in FORCED if _ok(rows, t)}
    if not cands or not _ok(rows, DEFAULT):
        return None, None
    best = min(cands, key=cands.get)
    return (rows[DEFAULT]["rms_permille"] + FLOOR) / (cands[best] + FLOOR), best


def cost(rows):
    """The default's fill seconds over the fastest forced order's (the
    choice's cost), or None."""
    t = [rows[f]["seconds"] for f in FORCED if rows.get(f, {}).get("status") == "ok"]
    d = rows.get(DEFAULT, {})
    if not t or d.get("status") != "ok" or min(t) <= 0:
        return None
    return d["seconds"] / min(t)


def summary(cases):
    r = np.array([c["regret"] for c in cases if c["regret"] is not None])
    if not len(r):
        return {"cases": 0}
    out = {"cases": int(len(r)), "geomean": round(float(np.exp(np.mean(np.log(r)))), 4),
           "max": round(float(r.max()), 4), "over_1.5": int((r > 1.5).sum()),
           "at_1": int((r <= 1.0 + 1e-9).sum())}
    c = np.array([x for x in (cost(k["rows"]) for k in cases) if x is not None])
    if len(c):
        out["cost_geomean"] = round(float(np.exp(np.mean(np.log(c)))), 3)
        out["cost_max"] = round(float(c.max()), 3)
    p = np.array([c["over_peer"] for c in cases if c.get("over_peer") is not None])
    if len(p):
        out["over_peer_cases"] = int(len(p))
        out["over_peer_median"] = round(float(np.median(p)), 4)
        out["over_peer_max"] = round(float(p.max()), 4)
        out["over_peer_over_1.1"] = int((p > 1.1).sum())
    rows = [k["rows"].get(DEFAULT, {}) for k in cases]
    holes = sum(r.get("reported_holes", 0) for r in rows)
    if holes:
        out["untold_share"] = round(sum(r.get("untold", 0) for r in rows) / holes, 4)
    return out


def markdown(cases, command):
    peers = [t for t in PEERS if any(t in c["rows"] for c in cases)]
    lines = [f"Command: `{command}`", "",
             "| case | default ‰ | o1 ‰ | o2 ‰ | o3 ‰ | flat ‰ | best | regret | cost |"
             + "".join(f" {t} ‰ |" for t in peers) + (" over best peer |" if peers else ""),
             "|---|---|---|---|---|---|---|---|---|" + "---|" * (len(peers) + bool(peers))]
    for c in cases:
        cell = lambda t: ("–" if c["rows"].get(t, {}).get("rms_permille") is None
                          else f"{c['rows'][t]['rms_permille']:.3g}"
                          + ("" if c["rows"][t]["holes_closed"] == c["rows"][t]["holes"] else " (open)"))
        lines.append(f"| {c['case']} | " + " | ".join(cell(t) for t in (DEFAULT,) + FORCED + SHOWN)
                     + f" | {c['best'] or '–'} | " + ("–" if c["regret"] is None else f"{c['regret']:.3f}")
                     + " | " + ("–" if cost(c["rows"]) is None else f"{cost(c['rows']):.2f}") + " |"
                     + "".join(f" {cell(t)} |" for t in peers)
                     + ((" – |" if c.get("over_peer") is None else f" {c['over_peer']:.3f} ({c['peer']}) |")
                        if peers else ""))
    s = summary(cases)
    lines += ["", f"- regret over {s.get('cases', 0)} cases: geometric mean {s.get('geomean')}, "
              f"max {s.get('max')}, over 1.5 on {s.get('over_1.5')}, at 1 on {s.get('at_1')}",
              f"- cost (the default's fill seconds over the fastest forced order's, in this process): "
              f"geometric mean {s.get('cost_geomean')}, max {s.get('cost_max')}",
              f"- holes where the scan could not tell (order 2 by default): {s.get('untold_share')}"]
    if s.get("over_peer_cases"):
        lines.append(f"- the default over the best peer that closed every hole, over {s['over_peer_cases']} cases: "
                     f"median {s['over_peer_median']}, max {s['over_peer_max']}, over 1.1 on {s['over_peer_over_1.1']}")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--n", type=int, default=24)
    p.add_argument("--start", type=int, default=0)
    p.add_argument("--quick", action="store_true", help="coarse procedural meshes, no real scans")
    p.add_argument("--peers", action="store_true", help="also run the installed peers (eval/peers.py)")
    p.add_argument("--out", type=Path, default=ROOT / "eval" / "results")
    p.add_argument("--ragged", type=float, default=0.0,
                   help="give every rim a scanner's ragged fringe: noise along the normal of this many mean "
                        "edge lengths (eval.stress.ragged_rims; the truth stays clean)")
    a = p.parse_args(argv)
    shapes_ok = stress.available_shapes(quick=a.quick)
    cases = []
    for i in range(a.start, a.start + a.n):
        case = stress.stress_case(i, a.seed, quick=a.quick, shapes_ok=shapes_ok, ragged=a.ragged)
        print(f"{case.name}: {len(case.F)} faces ({case.description})", flush=True)
        tools = (DEFAULT,) + FORCED + SHOWN
        if a.peers:
            tools += tuple(t for t in PEERS if peers.tool_available(t)[0])
        rows = run_case(case, tools)
        g, best = regret(rows)
        op, peer = over_peer(rows)
        print(f"  regret {g}, over the best peer {op} ({peer})", flush=True)
        cases.append({"case": case.name, "faces": int(len(case.F)), "rows": rows, "regret": None if g is None else round(g, 4), "best": best,
                      "over_peer": None if op is None else round(op, 4), "peer": peer})
    a.out.mkdir(parents=True, exist_ok=True)
    stem = a.out / f"regret-seed{a.seed}{'-quick' if a.quick else ''}{f'-ragged{a.ragged:g}' if a.ragged else ''}"
    command = "python eval/regret.py " + " ".join(argv if argv is not None else sys.argv[1:])
    # (not with_suffix: a stem such as "-ragged0.1" has a dot of its own)
    stem.parent.joinpath(stem.name + ".json").write_text(json.dumps({"command": command, "cases": cases,
                                                     "summary": summary(cases)}, indent=1))
    stem.parent.joinpath(stem.name + ".md").write_text(markdown(cases, command))
    print(markdown(cases, command))


if __name__ == "__main__":
    main()
