"""Compiled kernel of :class:`shellrepair.appearance.shader.MaterialShader` (Numba).

:func:`material_shader` is ``MaterialShader._eval`` fused into one pass
over the points: the microfacet arithmetic over rows of directions, then
the shader's Fresnel, rho_dt and R_eff tables.  It sits here, beside the
reflectance kernels whose helpers it inlines (:mod:`.common_kernels`),
rather than beside :mod:`shellrepair.appearance.shader`: the kernel modules at the
package's top (``shellrepair/*_kernels.py``) are the fill's, built ahead of
time (:mod:`shellrepair.compiled`), and import no subpackage.  Its NumPy
version (the test oracle): :meth:`shellrepair.appearance.shader.MaterialShader.evaluate_numpy`.
"""

from __future__ import annotations

import math

import numpy as np

from shellrepair.appearance.reflectance._constants import COS_EPS, M_MIN, MU_FLOOR
from shellrepair.appearance.reflectance.common_kernels import BLOCK, EPS2, PI, _at, _clip, _ftz_enter, _ftz_exit, _inline, _slp, _to_rows, jit, vexp


# --------------------------------------------------------------------------
# MaterialShader (shader.MaterialShader._eval fused)
# --------------------------------------------------------------------------


@_inline
def _rho_cj_1(u, j, b, rho4, nu, nc):
    fu = u * (nu - 1)
    i = min(np.int64(fu), nu - 2)
    a = fu - i
    row = i * (nc - 1) + j
    r0 = rho4[row, 0] + b * (rho4[row, 1] - rho4[row, 0])
    r1 = rho4[row, 2] + b * (rho4[row, 3] - rho4[row, 2])
    return r0 + a * (r1 - r0)


@_inline
def _spec_ch(Fpack, li, w, ch, gl, c, Ft, DG4, corrodes):
    """Specular f of one channel: the metals' Fresnel mixed by gilding, the patina's by coverage."""
    Fm = Fpack[li, ch] + w * Fpack[li, 7 + ch]  # gold
    Fb = Fpack[li, 3 + ch] + w * Fpack[li, 10 + ch]  # bronze
    Fmetal = gl * Fm + (1.0 - gl) * Fb
    return DG4 * ((1.0 - c) * Fmetal + c * Ft) if corrodes else DG4 * Fmetal


@jit
def material_shader(lo, hi, wi, wo, n, cov, gild, crust, m0, dm, n_lut, Fpack, corrodes, rho4, nu, nc,
                    R4, nrc, nrd, spec_out, diff_out, add):
    """One pass of MaterialShader._eval per point.

    Writes f_spec to spec_out and f_diffuse to diff_out, or their sum to
    spec_out when ``add`` is true (diff_out is then not touched).  Per
    block: the directions into rows, the microfacet arithmetic over the
    rows (vectorised), then the table lookups.
    """
    a = np.empty((9, BLOCK))
    g = np.empty((6, BLOCK))
    old = _ftz_enter()
    for i0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - i0)
        _to_rows(wi, i0, bn, a, 0)
        _to_rows(wo, i0, bn, a, 3)
        _to_rows(n, i0, bn, a, 6)
        cb = _slp(cov, i0, i0 + bn)
        for t in range(bn):
            w0, w1, w2, v0, v1, v2 = a[0, t], a[1, t], a[2, t], a[3, t], a[4, t], a[5, t]
            n0, n1, n2 = a[6, t], a[7, t], a[8, t]
            c = _clip(_at(cb, t), 0.0, 1.0)
            ni = n0 * w0 + n1 * w1 + n2 * w2
            no = n0 * v0 + n1 * v1 + n2 * v2
            io = w0 * v0 + w1 * v1 + w2 * v2
            hl2 = max(2.0 + 2.0 * io, 0.0)
            valid = (ni > COS_EPS) & (no > COS_EPS) & (hl2 > EPS2)
            nis = ni if valid else 1.0
            nos = no if valid else 1.0
            hls = hl2 if valid else 1.0
            inv_hl = 1.0 / math.sqrt(hls)
            nh = min((nis + nos) * inv_hl, 1.0)
            nfi = max(nis, MU_FLOOR)  # grazing guard of eq 8's denominator
            nfo = max(nos, MU_FLOOR)
            oh = min(0.5 * hls * inv_hl, 1.0)
            m = max(m0 + dm * c, M_MIN)
            inv_m2 = 1.0 / (m * m)
            nh2 = nh * nh
            D = vexp((nh2 - 1.0) / nh2 * inv_m2) * inv_m2 / (PI * nh2 * nh2)  # eq 13
            gg = min(1.0 / (nfi * nfo), 2.0 * nh / (max(oh, COS_EPS) * max(nfi, nfo)))  # eq 11 / (4 ni no)
            g[0, t] = 0.25 * D * gg if valid else 0.0  # DG4
            g[1, t] = oh
            g[2, t] = c
            g[3, t] = math.sqrt(nis)
            g[4, t] = math.sqrt(nos)
            g[5, t] = 1.0 if valid else 0.0
        gb = _slp(gild, i0, i0 + bn)
        db = _slp(crust, i0, i0 + bn)
        for t in range(bn):
            DG4 = g[0, t]
            c = g[2, t]
            # Fresnel: gold (3), bronze (3), dielectric (1), linear in o.h
            f = g[1, t] * (n_lut - 1)
            li = min(np.int64(f), n_lut - 1)
            w = f - li
            gl = _clip(_at(gb, t), 0.0, 1.0)
            Ft = Fpack[li, 6] + w * Fpack[li, 13]
            s0 = _spec_ch(Fpack, li, w, 0, gl, c, Ft, DG4, corrodes)
            s1 = _spec_ch(Fpack, li, w, 1, gl, c, Ft, DG4, corrodes)
            s2 = _spec_ch(Fpack, li, w, 2, gl, c, Ft, DG4, corrodes)
            d0 = 0.0
            d1 = 0.0
            d2 = 0.0
            if corrodes:
                fc = c * (nc - 1)
                j = min(np.int64(fc), nc - 2)
                b = fc - j
                rho = _rho_cj_1(g[3, t], j, b, rho4, nu, nc) * _rho_cj_1(g[4, t], j, b, rho4, nu, nc)
                diff = c * rho * (1.0 / PI) if g[5, t] > 0.0 else 0.0
                # R_eff(c, crust), bilinear
                fr = c * (nrc - 1)
                ri = min(np.int64(fr), nrc - 2)
                aa = fr - ri
                fd = _clip(_at(db, t), 0.0, 1.0) * (nrd - 1)
                rj = min(np.int64(fd), nrd - 2)
                bb = fd - rj
                row = ri * (nrd - 1) + rj
                r00 = R4[row, 0] + bb * (R4[row, 3] - R4[row, 0])
                r10 = R4[row, 6] + bb * (R4[row, 9] - R4[row, 6])
                r01 = R4[row, 1] + bb * (R4[row, 4] - R4[row, 1])
                r11 = R4[row, 7] + bb * (R4[row, 10] - R4[row, 7])
                r02 = R4[row, 2] + bb * (R4[row, 5] - R4[row, 2])
                r12 = R4[row, 8] + bb * (R4[row, 11] - R4[row, 8])
                d0 = diff * (r00 + aa * (r10 - r00))
                d1 = diff * (r01 + aa * (r11 - r01))
                d2 = diff * (r02 + aa * (r12 - r02))
            i = i0 + t
            if add:
                spec_out[i, 0] = s0 + d0
                spec_out[i, 1] = s1 + d1
                spec_out[i, 2] = s2 + d2
            else:
                spec_out[i, 0] = s0
                spec_out[i, 1] = s1
                spec_out[i, 2] = s2
                diff_out[i, 0] = d0
                diff_out[i, 1] = d1
                diff_out[i, 2] = d2
    _ftz_exit(old)


#: The kernels of this module, by name (for warm_up's count and the tests).
KERNELS = ("material_shader",)
