"""Speed-versus-error picture of a benchmark run (PNG).

One point per (case, tool) that returned a surface: x is the fill time in
seconds, y the RMS distance to the truth in ‰ of the bounding-box diagonal,
both on log scales; each tool's median over the cases is a large marker.
Lower left is better. Drawn with matplotlib when it is installed (the
``bench`` extra), otherwise with Pillow (a dependency of open3d's stack)
so the picture is always written.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["speed_vs_error", "points_by_tool"]

PALETTE = ["#d62728", "#ff7f0e", "#8c564b", "#e377c2", "#1f77b4", "#2ca02c", "#9467bd", "#17becf",
           "#bcbd22", "#7f7f7f", "#393b79", "#637939"]
#: Floors of the log axes, so a zero does not vanish.
MIN_SECONDS = 1e-4
MIN_RMS = 1e-4


def points_by_tool(rows, tools):
    """{tool: (seconds array, rms array)} from the result rows."""
    out = {}
    for t in tools:
        s, r = [], []
        for row in rows:
            if row["tool"] != t or row.get("status") != "ok" or row.get("rms_permille") is None:
                continue
            s.append(max(float(row["seconds"]), MIN_SECONDS))
            r.append(max(float(row["rms_permille"]), MIN_RMS))
        out[t] = (np.array(s), np.array(r))
    return out


def speed_vs_error(rows, tools, path, title="speed vs error"):
    """Write the PNG; returns the backend used ('matplotlib' or 'pillow')."""
    pts = points_by_tool(rows, tools)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        _pillow(pts, tools, path, title)
        return "pillow"
    fig, ax = plt.subplots(figsize=(9, 6), dpi=110)
    for i, t in enumerate(tools):
        s, r = pts[t]
        if len(s) == 0:
            continue
        c = PALETTE[i % len(PALETTE)]
        ax.scatter(s, r, s=14, color=c, alpha=0.45, linewidths=0)
        ax.scatter([np.median(s)], [np.median(r)], s=110, color=c, edgecolors="black", label=t, zorder=3,
                   marker="o" if t.startswith("ours") else "s")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("fill time per case [s] (log)")
    ax.set_ylabel("RMS distance to the true surface [‰ of bbox diagonal] (log)")
    ax.set_title(title + "  (small: each case; large: median per tool; lower left is better)", fontsize=9)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return "matplotlib"


def _pillow(pts, tools, path, title):
    from PIL import Image, ImageDraw

    W, H = 1000, 660
    L, R, T, B = 90, 210, 50, 70
    img = Image.new("RGB", (W, H), "white")
    d = ImageDraw.Draw(img)
    alls = np.concatenate([pts[t][0] for t in tools if len(pts[t][0])] or [np.array([1e-2, 1.0])])
    allr = np.concatenate([pts[t][1] for t in tools if len(pts[t][1])] or [np.array([1e-2, 1.0])])
    x0, x1 = math.floor(math.log10(alls.min())), math.ceil(math.log10(alls.max()))
    y0, y1 = math.floor(math.log10(allr.min())), math.ceil(math.log10(allr.max()))
    x1 = max(x1, x0 + 1)
    y1 = max(y1, y0 + 1)

    def X(s):
        return L + (math.log10(s) - x0) / (x1 - x0) * (W - L - R)

    def Y(r):
        return H - B - (math.log10(r) - y0) / (y1 - y0) * (H - T - B)

    d.rectangle([L, T, W - R, H - B], outline="black")
    for e in range(x0, x1 + 1):
        x = X(10.0 ** e)
        d.line([x, T, x, H - B], fill="#dddddd")
        d.text((x - 12, H - B + 6), f"1e{e}", fill="black")
    for e in range(y0, y1 + 1):
        y = Y(10.0 ** e)
        d.line([L, y, W - R, y], fill="#dddddd")
        d.text((L - 40, y - 6), f"1e{e}", fill="black")
    d.text((L, H - B + 30), "fill time per case [s] (log); lower left is better", fill="black")
    d.text((10, T - 30), "RMS distance to the true surface [permille of bbox diagonal] (log)", fill="black")
    d.text((L, 8), title + "  (small: each case; large: median per tool)", fill="black")
    for i, t in enumerate(tools):
        s, r = pts[t]
        c = PALETTE[i % len(PALETTE)]
        for a, b in zip(s, r):
            x, y = X(a), Y(b)
            d.ellipse([x - 3, y - 3, x + 3, y + 3], fill=c)
        ly = T + 10 + 20 * i
        d.rectangle([W - R + 15, ly, W - R + 27, ly + 12], fill=c, outline="black")
        d.text((W - R + 33, ly), t, fill="black")
        if len(s):
            x, y = X(float(np.median(s))), Y(float(np.median(r)))
            if t.startswith("ours"):
                d.ellipse([x - 8, y - 8, x + 8, y + 8], fill=c, outline="black", width=2)
            else:
                d.rectangle([x - 7, y - 7, x + 7, y + 7], fill=c, outline="black", width=2)
    img.save(path)
