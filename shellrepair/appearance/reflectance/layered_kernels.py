"""Compiled kernels of the layered BRDF (Numba): :mod:`.layered` (eq 2).

:func:`layered_diffuse` (rho_dt at both directions, the internal
reflections of the layer stack) and :func:`local_brdf` (that plus the
Torrance-Sparrow lobe of :mod:`.microfacet_kernels`), from the table reads
of :mod:`.albedo_kernels`.  How they are made fast: :mod:`.common_kernels`;
their NumPy versions: :mod:`.reference`.
"""

from __future__ import annotations

import numpy as np

from shellrepair.appearance.reflectance._constants import COS_EPS, _TINY
from shellrepair.appearance.reflectance.albedo_kernels import mean_combine, mean_index, rho_combine, rho_index
from shellrepair.appearance.reflectance.common_kernels import BLOCK, PI, _at, _clip, _ftz_enter, _ftz_exit, _inline, _slp, _to_rows, _vec, jit
from shellrepair.appearance.reflectance.microfacet_kernels import _mf_row, fresnel_dielectric_1


@_inline
def _layered_block(ci, co, m, eta, bn, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi,
                   ix, wt, sc):
    """layered_diffuse's per-point factors of a block into sc[0] (scale) and sc[1] (r_i).

    ci, co, m, eta: the block's values (rows of length bn, or scalars).
    Indices and weights of the two rho_dt reads and the rho_bar read
    first (vectorised), then the reads.
    """
    NK = Kp.shape[0]
    K_first, K_step, K_last = Kp[0], Kp[1] - Kp[0], Kp[NK - 1]
    for t in range(bn):
        mt = _at(m, t)
        et = _at(eta, t)
        i0, i1, wu0, wu1, wj, wk = rho_index(_at(ci, t), mt, et, K_first, K_step, K_last, NK, dk0, k0, U0, dU,
                                             NU, L0, dL, NL)
        ix[0, t] = i0
        ix[1, t] = i1
        wt[0, t] = wu0
        wt[1, t] = wu1
        wt[2, t] = wj
        wt[3, t] = wk
        i0, i1, wu0, wu1, wj, wk = rho_index(_at(co, t), mt, et, K_first, K_step, K_last, NK, dk0, k0, U0, dU,
                                             NU, L0, dL, NL)
        ix[2, t] = i0
        ix[3, t] = i1
        wt[4, t] = wu0
        wt[5, t] = wu1
        wt[6, t] = wj
        wt[7, t] = wk
        j, k, wj, wk, cq, kap_c = mean_index(mt, et, K_first, K_step, K_last, NK, dk0, k0, L0, dL, NL)
        ix[4, t] = j
        ix[5, t] = k
        wt[8, t] = wj
        wt[9, t] = wk
        wt[10, t] = cq
        wt[11, t] = kap_c
    for t in range(bn):
        t_i = _clip(rho_combine(vals, NL, NK, ix[0, t], ix[1, t], wt[0, t], wt[1, t], wt[2, t], wt[3, t]),
                    0.0, 1.0)  # eq 3 at wi
        t_o = _clip(rho_combine(vals, NL, NK, ix[2, t], ix[3, t], wt[4, t], wt[5, t], wt[6, t], wt[7, t]),
                    0.0, 1.0)  # eq 3 at wo
        rho_bar = mean_combine(ix[4, t], ix[5, t], wt[8, t], wt[9, t], wt[10, t], wt[11, t], dk0, k0,
                               M, P, Q0, Q1)
        e = _clip(_at(eta, t), e_lo, e_hi)
        r_i = _clip(1.0 - rho_bar / (e * e), 0.0, 1.0 - 1e-9)
        above = (_at(ci, t) > COS_EPS) & (_at(co, t) > COS_EPS)
        sc[0, t] = t_i * t_o * (1.0 - r_i) / (PI * max(rho_bar, _TINY)) if above else 0.0
        sc[1, t] = r_i


@jit
def layered_diffuse(lo, hi, ci, co, m, eta, R, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi,
                    out):
    C = out.shape[1]
    ix = np.empty((6, BLOCK), dtype=np.int64)
    wt = np.empty((12, BLOCK))
    sc = np.empty((2, BLOCK))
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        _layered_block(_slp(ci, b0, b0 + bn), _slp(co, b0, b0 + bn), _slp(m, b0, b0 + bn), _slp(eta, b0, b0 + bn),
                       bn, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi, ix, wt, sc)
        for t in range(bn):
            for ch in range(C):
                Rc = _vec(R, b0 + t, ch)
                out[b0 + t, ch] = sc[0, t] * Rc / (1.0 - sc[1, t] * Rc)  # eq 2 with internal reflections
    _ftz_exit(old)


@jit
def local_brdf(lo, hi, wi, wo, n, m, eta, R, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi,
               out):
    C = out.shape[1]
    a = np.empty((9, BLOCK))
    g = np.empty((3, BLOCK))
    ix = np.empty((6, BLOCK), dtype=np.int64)
    wt = np.empty((12, BLOCK))
    sc = np.empty((2, BLOCK))
    old = _ftz_enter()
    for i0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - i0)
        _to_rows(wi, i0, bn, a, 0)
        _to_rows(wo, i0, bn, a, 3)
        _to_rows(n, i0, bn, a, 6)
        mb = _slp(m, i0, i0 + bn)
        eb = _slp(eta, i0, i0 + bn)
        for t in range(bn):
            DG4, oh, ni, no = _mf_row(a, t, _at(mb, t))
            g[0, t] = DG4 * fresnel_dielectric_1(oh, _at(eb, t))  # eq 8
            g[1, t] = ni
            g[2, t] = no
        _layered_block(g[1, :bn], g[2, :bn], mb, eb, bn, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1,
                       e_lo, e_hi, ix, wt, sc)
        for t in range(bn):
            for ch in range(C):
                Rc = _vec(R, i0 + t, ch)
                out[i0 + t, ch] = g[0, t] + sc[0, t] * Rc / (1.0 - sc[1, t] * Rc)
    _ftz_exit(old)


#: The kernels of this module, by name (for warm_up's count and the tests).
KERNELS = ("layered_diffuse", "local_brdf")
