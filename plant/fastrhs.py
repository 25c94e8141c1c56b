"""Fast right-hand side of the plant for the usual operating case (docs/plant.md, Integration).

``FastRHS.rhs`` evaluates the same equations as ``Plant._rhs_general`` + ``TurbineBank.rhs`` with
fewer numpy calls (about 33 instead of 47; each call costs more than the arithmetic of 50 turbines):

* every intermediate is written (``out=``) into a row of one persistent, contiguous feature
  array ``F`` (N columns); the nine derivative rows, the five limiter conditions (V_d floor /
  grid-following current limit, modulation limit, MSC power clip both ways, braking chopper) and
  omega_meas are all linear in these rows and come out of one real matrix product ``M @ F``
  (``M`` holds the constant gains and the held V_d threshold); the limiter rows are then
  checked by a single reduction;
* the current row is the last row of ``F`` and is followed by two spare entries, so together
  they form the source vector of the reduced network solve (``Network.factorize``).

It applies only while the slow terms are held, all turbines are plugged and no battery is
enabled; if one of these fails or a limiter would act it returns None and the plant uses the
general path, whose results it reproduces to rounding (the linear combinations are summed in a
different order).
"""

from __future__ import annotations

import cmath

import numpy as np

from plant import turbine as T
from plant.condenser import DELTA, ED2, EQ2
from plant.condenser import NX as SC_NX
from sdvisc.vocabulary import OMEGA0

_max = np.maximum.reduce
# rows of the feature array F; CUR (turbine currents) must be the last one
G, E, VP, PCONV = range(4)  # complex
EV, XP, PME, EDC, PMEH, VDC, VM, PAH, DB, DXB, PAV, ONE = range(4, 16)  # real
CUR = 16
K = 17
# rows of the product M @ F: limiter checks (<= 0 when inactive), omega_meas - 1, then dS
NCHK = 5
OM = NCHK
D0 = NCHK + 1


class FastRHS:
    """Preallocated buffers and the gain matrix of the fast right-hand side of one Plant."""

    def __init__(self, plant):
        self.pl = plant
        n = self.n = plant.n
        tp = plant.params.turbine
        flat = np.zeros(K * n + 2, dtype=complex)
        self.F = F = flat[: K * n].reshape(K, n)
        self.u = flat[CUR * n:]  # [i, E_g Y_g - I_load, E'' Y'']
        self.Fv = F.view(float)  # (K, 2n)
        self.row = list(F)
        self.rrow = list(F.real)
        self.rrow[ONE][:] = 1.0
        w0lf = OMEGA0 / tp.lf
        M = np.zeros((D0 + T.NS, K))
        M[0, VP] = -1.0  # vd_ok - V_d (M[0, ONE] = vd_ok is set with the held slow terms)
        M[1, VM], M[1, VDC] = 1.0, -tp.m_max  # |v_conv| - m_max v_dc
        M[2, PME], M[2, PAV] = 1.0, -1.0  # P_me - P_avail
        M[3, ONE], M[3, PME] = tp.p_me_min, -1.0  # p_me_min - P_me
        M[4, VDC], M[4, ONE] = 1.0, -tp.v_chop  # v_dc - v_chop
        M[OM, EV], M[OM, XP] = tp.kp_pll, 1.0  # omega_meas - 1
        d = D0
        M[d + T.IF, G], M[d + T.IF, CUR] = w0lf, -w0lf * tp.rf  # (v_conv - v - (rf + j lf) i) w0/lf
        M[d + T.XI, E] = 1.0
        M[d + T.TH, EV], M[d + T.TH, XP] = OMEGA0 * tp.kp_pll, OMEGA0
        M[d + T.XP, EV] = tp.ki_pll
        M[d + T.W, PME], M[d + T.W, PCONV] = 2.0 / tp.tau_dc, -2.0 / tp.tau_dc
        M[d + T.XD, EDC] = tp.ki_dc
        M[d + T.WR, PAH], M[d + T.WR, PMEH] = 1.0, -1.0
        M[d + T.B, DB] = M[d + T.XB, DXB] = 1.0
        self.M = M
        self.nd = (D0 + T.NS) * 2 * n  # floats of the product
        self._slow = None

    def _hold(self, sl) -> None:
        """Copy the held slow terms and limiter thresholds into F and M (once per slow evaluation)."""
        r = self.rrow
        np.multiply(sl["paero"], sl["inv2hw"], out=r[PAH])
        r[DB][:] = sl["db"]
        r[DXB][:] = sl["dxb"]
        r[PAV][:] = sl["pav"]
        self.M[0, ONE] = sl["vd_ok"]
        self._slow = sl

    def rhs(self, X, xl, want_aux):
        """(dX, dxl, aux) as ``Plant._rhs``, or None when the general path is needed."""
        pl = self.pl
        tb, net = pl.tb, pl.net
        sl = tb.slow
        if sl is None or sl["any_batt"] or not net.all_plugged:
            return None
        if sl is not self._slow:
            self._hold(sl)
        n, c, row, rrow = self.n, tb._c, self.row, self.rrow
        S = X[: pl.o_sc].reshape(T.NS, n)
        # ---------------------------------------------------------------- network (as pl._rhs_general)
        g = pl.params.grid
        tail = X.real[pl.o_sc:].tolist()
        thg = tail[SC_NX]
        e_grid = g.e_grid * cmath.exp(1j * thg) if thg != 0.0 else complex(g.e_grid)
        e_sc = complex(tail[EQ2], -tail[ED2]) * cmath.exp(1j * tail[DELTA]) if net.sc_connected else 0.0j
        vl = pl._v_pcc_last
        i_load = pl.load_s.conjugate() * vl / max(abs(vl) ** 2, 0.49) if pl.load_s else 0.0j
        u = self.u
        i = row[CUR]
        i[:] = S[T.IF]
        u[n] = e_grid * net.y_grid - i_load
        u[n + 1] = e_sc * net.y_sc
        Vr = np.dot(net.zred, u)
        v = Vr[:n]
        ext, any_ext, any_rem = pl._mode_info()
        dxl = law_out = None
        vext = tb.v_hold
        if any_rem and pl.params.turbine.remote_apply == "i_ref":
            tp = pl.params.turbine
            ih = tb.i_hold
            vext = np.where(tb.mode == T.REMOTE, v + (tp.rf + 1j * tp.lf) * ih + tp.kpc * (ih - i), vext)
        if pl.visc_idx.size:
            vext, dxl, law_out = pl._visc(S, v, xl, vext)
        # ---------------------------------------------------------------- turbines (as tb.rhs)
        rotc = np.exp(S[T.TH] * c["-j"])  # e^{-j theta} (the TH row has a zero imaginary part)
        vp = np.multiply(v, rotc, out=row[VP])
        np.divide(vp.imag, np.abs(v), out=rrow[EV])  # PLL error
        e = np.subtract(sl["sref"] / vp.real, i * rotc, out=row[E])
        q = c["kpc"] * e
        q += c["kic"] * S[T.XI]
        gr = np.multiply(q, rotc.conj(), out=row[G])  # v_conv - v - j lf i
        ji = c["jlf"] * i
        vconv = v + ji
        vconv += gr
        if any_ext:  # remote / hd_visc: v_conv = vext, current-PI integrator frozen
            gx = vext - v
            gx -= ji
            np.copyto(gr, gx, where=ext)
            np.copyto(vconv, vext, where=ext)
            np.copyto(e, 0.0, where=ext)
        vdc = np.sqrt(np.maximum(S.real[T.W], c["1e-4"]), out=rrow[VDC])
        np.abs(vconv, out=rrow[VM])
        edc = np.subtract(c["vdc_ref"], vdc, out=rrow[EDC])
        pme = np.multiply(c["kp_dc"], edc, out=rrow[PME])
        pme += S.real[T.XD]
        ic = i.conj()
        np.multiply(vconv, ic, out=row[PCONV])  # P_conv in the real part
        np.multiply(pme, sl["inv2hw"], out=rrow[PMEH])
        row[XP][:] = S[T.XP]
        buf = np.empty(self.nd + 2 * (X.size - T.NS * n))
        P = buf[: self.nd].reshape(D0 + T.NS, 2 * n)
        np.dot(self.M, self.Fv, out=P)
        if _max(P[:NCHK, ::2], axis=None) > 0.0:  # a limiter would act: general path
            return None
        dX = buf[D0 * 2 * n:].view(complex)
        dX.imag[T.W * n:(T.W + 1) * n] = 0.0  # the imaginary part of the P_conv row entered here
        # ---------------------------------------------------------------- condenser, grid, PCC PLL
        vp, vsc = Vr[n:].tolist()
        dX[pl.o_sc:], i_sc, f_pcc = pl._tail_rhs(tail, vp, vsc, e_grid, e_sc)
        if not want_aux:
            return dX, dxl, None
        aux = {"vconv": vconv, "vdc": vdc.copy(), "pme": pme.copy(), "pbatt": 0.0, "paero": sl["paero"],
               "vlim": tb._false, "om": P[OM, ::2] + 1.0, "s": v * ic, "Vr": Vr,
               "v": v, "i": S[T.IF].copy(), "i_sc": i_sc, "e_grid": e_grid, "e_sc": e_sc, "i_load": i_load,
               "law_out": law_out, "v_pcc": vp, "v_sc": vsc, "f_pcc": f_pcc}
        return dX, dxl, aux
