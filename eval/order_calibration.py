"""How well the order test's verdict predicts the truth, hole by hole.

``python eval/order_calibration.py --seed 11 --n 12`` builds stress cases
``0..n-1`` of the seed (:func:`eval.stress.stress_case`), repairs each
with ``order="auto"`` and with each order forced (1, 2, 3), and, for every
hole the order test judged (the report row's ``choice`` with test RMS),
measures each forced order's patch against the truth (RMS of its face
centroids and vertices to the truth surface, per mille of the truth's
diagonal). A patch is given to the hole whose rim it touches: the filled
faces are split into pieces joined by shared new vertices, and each piece
goes to the loop of the input whose rim vertices it uses.

It writes ``<out>/order-calibration-seed<seed>.json`` (per hole: the
test's RMS per order, its scale and number of test holes, the hole's
radius, the truth RMS per order) and ``.md``:

* the test's o3/o2 ratio in bins, against the truth's o3/o2 ratio in the
  same holes (how often order 3 was truer, the geometric mean of the
  truth's ratio): where the two agree, the test's verdict carries the
  truth's sign; where the bins' truth ratios are all alike, the test does
  not tell order 2 from order 3;
* the same for o1 against the better of o2 and o3;
* the per-hole regret of the test's pick, (picked + floor) / (best + floor),
  and the holes with the largest.

This is a measurement of the criterion (issue 36), not a tuning step: run
it on design seeds (below 1000) when changing the test, and on validation
seeds to report.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from eval import stress  # noqa: E402

ORDERS = ("1", "2", "3")
#: Per mille of the diagonal added to both sides of a ratio (as eval/regret.py).
FLOOR = 0.05
#: Bins of the test's ratio of one candidate's RMS over another's.
BINS = (0.0, 0.8, 0.95, 1.05, 1.25, np.inf)


def patches_by_loop(V_in, F_in, V_out, F_out, loops):
    """{loop index: (faces of the output filled for that loop)}.

    The output keeps the input's vertices first and its faces first
    (shellrepair's promise); the faces after them are split into pieces
    joined by shared vertices that are new, and each piece is given to the
    input loop whose rim vertices it uses most (a tube touching two loops
    goes to the one with more rim vertices in it, ties to the lower index).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n_in, m_in = len(V_in), len(F_in)
    T = np.asarray(F_out[m_in:], np.int64)
    if not len(T):
        return {}
    m = len(T)
    # faces joined through a new vertex
    fid = np.repeat(np.arange(m), 3)
    vid = T.ravel()
    new = vid >= n_in
    g = coo_matrix((np.ones(int(new.sum()), np.int8), (fid[new], vid[new] - n_in)),
                   shape=(m, max(1, len(V_out) - n_in))).tocsr()
    adj = g @ g.T
    _, lab = connected_components(adj, directed=False)
    owner = np.full(n_in, -1, np.int64)
    for i, L in enumerate(loops):
        owner[np.asarray(L, np.int64)] = i
    out = {}
    for c in range(int(lab.max()) + 1):
        faces = np.flatnonzero(lab == c)
        used = np.unique(T[faces])
        used = used[used < n_in]
        ids = owner[used]
        ids = ids[ids >= 0]
        if not len(ids):
            continue
        k = int(np.argmax(np.bincount(ids)))
        out.setdefault(k, []).append(faces + m_in)
    return {k: np.concatenate(v) for k, v in out.items()}


def patch_rms(V, F, faces, truth_V, truth_F, diag):
    """RMS distance of a patch's face centroids and vertices to the truth, per mille of ``diag``."""
    from shellrepair.mesh.distance import point_mesh_distance

    T = F[faces]
    P = np.concatenate([V[T].mean(axis=1), V[np.unique(T)]])
    d = point_mesh_distance(P, truth_V, truth_F)
    return 1000.0 * float(np.sqrt(np.mean(d * d))) / diag


def run_case(case):
    """Per judged hole of one case: the test's verdict and each forced order's truth RMS."""
    from shellrepair.fill.probe import hole_radius
    from shellrepair.holes.loops import detect_holes
    from shellrepair.mesh.io import Mesh
    from shellrepair.repair import repair_mesh

    diag = float(np.linalg.norm(case.V_true.max(axis=0) - case.V_true.min(axis=0)))
    scan = detect_holes(case.V, case.F)
    loops = [L.vertices for L in scan.loops]
    index = {L.id: i for i, L in enumerate(scan.loops)}
    rms, judged = {}, {}
    for order in ("auto",) + ORDERS:
        M, report = repair_mesh(Mesh(V=case.V, F=case.F), order=order if order == "auto" else int(order))
        parts = patches_by_loop(case.V, case.F, M.V, M.F, loops)
        for row in report["holes"]:
            i = index.get(row["id"])
            if i is None or i not in parts or row["status"] != "filled":
                continue
            rms.setdefault(row["id"], {})[order] = patch_rms(M.V, M.F, parts[i], case.V_true, case.F_true, diag)
            ch = row.get("choice") or {}
            if order == "auto" and ch.get("test_rms"):
                judged[row["id"]] = {"edges": row["edges"], "pick": str(ch["order"]), "scale": ch["scale"],
                                     "probes": ch.get("probes"),
                                     "radius": hole_radius(case.V, loops[i]),
                                     "test": {str(k): float(v) for k, v in ch["test_rms"].items()}}
    holes = []
    for h, j in sorted(judged.items()):
        t = rms.get(h, {})
        if all(o in t for o in ORDERS):
            holes.append(dict(j, id=int(h), truth={o: t[o] for o in ORDERS}, auto=t.get("auto")))
    return holes


def _ratio(a, b):
    return (a + FLOOR) / (b + FLOOR)


def calibration(holes, num, den):
    """Rows (bin, holes, share where ``num`` was truer, geometric mean of the truth's ratio)."""
    rows = []
    for lo, hi in zip(BINS[:-1], BINS[1:]):
        sel = []
        for h in holes:
            d = min(h["test"][o] for o in den)
            if d <= 0:
                continue
            if lo <= h["test"][num] / d < hi:
                sel.append(np.log(_ratio(h["truth"][num], min(h["truth"][o] for o in den))))
        if sel:
            sel = np.array(sel)
            rows.append((f"{lo:g}-{hi:g}", len(sel), float((sel < 0).mean()), float(np.exp(sel.mean()))))
    return rows


def markdown(holes, command):
    lines = [f"Command: `{command}`", ""]
    for num, den, what in (("3", ("2",), "order 3 over order 2"), ("1", ("2", "3"), "order 1 over the better of 2 and 3")):
        lines += [f"Test RMS ratio of {what}, against the truth's ratio in the same holes:", "",
                  "| test ratio | holes | truth: first truer | truth ratio (geomean) |", "|---|---|---|---|"]
        lines += [f"| {b} | {n} | {s:.2f} | {g:.3f} |" for b, n, s, g in calibration(holes, num, den)]
        lines.append("")
    reg = sorted(((_ratio(h["truth"][h["pick"]], min(h["truth"].values())), h) for h in holes),
                 key=lambda t: -t[0])
    r = np.array([x for x, _ in reg]) if reg else np.ones(1)
    lines += [f"- per-hole regret of the test's pick over {len(reg)} judged holes: geometric mean "
              f"{float(np.exp(np.log(r).mean())):.3f}, over 1.5 on {int((r > 1.5).sum())}", "",
              "| case | hole | edges | scale | pick | test RMS 1 / 2 / 3 | truth ‰ 1 / 2 / 3 | regret |",
              "|---|---|---|---|---|---|---|---|"]
    for x, h in reg[:15]:
        lines.append(f"| {h['case']} | {h['id']} | {h['edges']} | {h['scale']:g} | {h['pick']} | "
                     + " / ".join(f"{h['test'][o]:.3g}" for o in ORDERS) + " | "
                     + " / ".join(f"{h['truth'][o]:.3g}" for o in ORDERS) + f" | {x:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--n", type=int, default=12)
    p.add_argument("--start", type=int, default=0)
    p.add_argument("--out", type=Path, default=ROOT / "eval" / "results" / "order-test")
    a = p.parse_args(argv)
    shapes_ok = stress.available_shapes()
    holes = []
    for i in range(a.start, a.start + a.n):
        case = stress.stress_case(i, a.seed, shapes_ok=shapes_ok)
        print(f"{case.name}: {len(case.F)} faces ({case.description})", flush=True)
        for h in run_case(case):
            holes.append(dict(h, case=case.name))
    a.out.mkdir(parents=True, exist_ok=True)
    stem = a.out / f"order-calibration-seed{a.seed}"
    command = "python eval/order_calibration.py " + " ".join(argv if argv is not None else sys.argv[1:])
    stem.with_suffix(".json").write_text(json.dumps({"command": command, "holes": holes}, indent=1))
    text = markdown(holes, command)
    stem.with_suffix(".md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
