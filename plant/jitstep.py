"""The plant's usual-case step compiled with numba (docs/plant.md, Integration, "Compiled path").

Why: the numpy fast path (fastrhs.py) spends its ~100 microseconds per step on per-call
overhead (dozens of numpy calls on 50-element arrays per right-hand side), not on arithmetic.
Compiled, one whole ETD2 step -- the stage-2 right-hand side, the update and the evaluation of
the new state that the next step reuses -- is one call of loops over the turbines.

What: ``_rhs`` is ``FastRHS.rhs`` (same equations, same operands, same limiter conditions):
reduced network solve (``Network.zred``, split into real and imaginary planes, transposed, so
the mat-vec vectorises), the turbine right-hand side with the held slow terms (remote turbines
with ``remote_apply == "i_ref"`` included), the condenser, grid source and PCC PLL tail of
``Plant._tail_rhs``. ``step`` is the unrolled ETD2 update of ``Plant.step`` around two of them,
``evaluate`` one evaluation with its aux, ``slow_terms`` ``TurbineBank.slow_terms``. Whenever a
limiter would act (V_d floor / current limit, modulation limit, MSC clip, chopper) a kernel
returns a failure code and ``JitPath`` lets the numpy code do that evaluation (fast or general
path); cases the compiled path does not cover at all (hd_visc law states, batteries, unplugged
turbines, slow terms evaluated per stage, rk2/rk4/substeps) always run the numpy code, which
stays the reference: a unit test holds both paths to the same trajectories
(tests/unit/test_plant_jit.py).

Turbine gains are frozen at construction (as in FastRHS); grid, condenser, load and AVR values
are copied into the constants vector whenever the slow terms are re-evaluated, which every
command causes. Every evaluation writes into freshly allocated arrays, so measurement and output
arrays handed out earlier are never overwritten.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from numba import njit

from plant import turbine as T
from plant.condenser import DELTA, ED2, EFD, EQ1, EQ2, OMEGA, XLL
from plant.condenser import NX as SC_NX
from sdvisc.vocabulary import OMEGA0

NS = T.NS
IF, XI, TH, XP, W, XD, WR, B, XB = T.IF, T.XI, T.TH, T.XP, T.W, T.XD, T.WR, T.B, T.XB
GFL, REMOTE = T.GFL, T.REMOTE
# constants vector K (float64)
(KPC, KIC, LF, W0LF, W0LFRF, W0KP, KIPLL, MMAX, VDCREF, KPDC, TWO_TDC, KIDC, PMEMIN, VCHOP, KPPLL,
 VDOK, EG, YG_RE, YG_IM, YSC_RE, YSC_IM, LOAD_RE, LOAD_IM, VL_RE, VL_IM,
 SCON, AVRPCC, VREF, Z2_RE, Z2_IM, MQ, AVRK, TATB, TA1, TE, EFDMAX, EFDMIN, H2, DSC, XDD1, XD12, XQD2,
 TD01, TD02, TQ02, TB, HG, GSCALE, DG, RGOV, TGOV, PM0, RF, IREF) = range(54)
NK = 54
# rows of the held slow terms SL (float64, (NSL, n))
SREF_RE, SREF_IM, PAH, INV2HW, DB, DXB, PAV = range(7)
NSL = 7
PAERO = 7  # further row of the slow_terms output
# rows of the per-evaluation real output A: measurements first (plant.measurements order)
MEAS_KEYS = ("v_d", "v_q", "i_d", "i_q", "p", "q", "v_dc", "omega_meas")
A_VDC, A_OM, A_PME, A_VC_RE, A_VC_IM = 6, 7, 8, 9, 10
NA = 11
# complex scalars Z of an evaluation
Z_ISC, Z_EG, Z_ESC, Z_ILOAD, Z_FPCC = range(5)
NZ = 5


@njit(cache=True, error_model="numpy")  # IEEE division as in numpy
def _rhs(X, K, SL, mode, vext, ihold, ZP, dX, Vr, A, Z, want):
    """Right-hand side of the plant state X into dX (FastRHS.rhs). Returns False (dX incomplete)
    if a limiter would act. ``mode``: TurbineBank.mode; ``vext``, ``ihold``: the held remote
    references. ``ZP``: real and imaginary plane of ``Network.zred``, transposed.
    ``want``: also write the reduced voltages Vr, the rows of A and the scalars Z (aux)."""
    ZR = ZP[0]
    ZI = ZP[1]
    n = SL.shape[1]
    m = n + 2
    o = NS * n
    # ---------------------------------------------------------------- sources (Plant._rhs_general)
    thg = X[o + SC_NX].real
    if thg != 0.0:
        e_grid = K[EG] * cmath.exp(1j * thg)
    else:
        e_grid = complex(K[EG], 0.0)
    scon = K[SCON] != 0.0
    if scon:
        e_sc = complex(X[o + EQ2].real, -X[o + ED2].real) * cmath.exp(1j * X[o + DELTA].real)
    else:
        e_sc = 0j
    load = complex(K[LOAD_RE], K[LOAD_IM])
    if load != 0j:
        vl = complex(K[VL_RE], K[VL_IM])
        i_load = load.conjugate() * vl / max(abs(vl) ** 2, 0.49)
    else:
        i_load = 0j
    ug = e_grid * complex(K[YG_RE], K[YG_IM]) - i_load
    usc = e_sc * complex(K[YSC_RE], K[YSC_IM])
    # ---------------------------------------------------------------- reduced network solve
    vr = np.zeros(m)
    vi = np.zeros(m)
    for c in range(m):
        if c < n:
            uc = X[c]
        elif c == n:
            uc = ug
        else:
            uc = usc
        ur = uc.real
        ui = uc.imag
        for r in range(m):
            vr[r] += ZR[c, r] * ur - ZI[c, r] * ui
            vi[r] += ZR[c, r] * ui + ZI[c, r] * ur
    # ---------------------------------------------------------------- turbines (TurbineBank.rhs)
    kpc, kic, lf, w0lf, w0lfrf = K[KPC], K[KIC], K[LF], K[W0LF], K[W0LFRF]
    w0kp, kipll, mmax, vdcref, kpdc = K[W0KP], K[KIPLL], K[MMAX], K[VDCREF], K[KPDC]
    two_tdc, kidc, pmemin, vchop, kppll, vdok = K[TWO_TDC], K[KIDC], K[PMEMIN], K[VCHOP], K[KPPLL], K[VDOK]
    jlf = complex(0.0, lf)
    zf = complex(K[RF], lf)
    iref = K[IREF] != 0.0
    for j in range(n):
        v = complex(vr[j], vi[j])
        i = X[IF * n + j]
        th = X[TH * n + j].real
        xp = X[XP * n + j].real
        rc = complex(math.cos(th), -math.sin(th))  # e^{-j theta}
        vp = v * rc
        vd = vp.real
        if vdok - vd > 0.0:  # V_d floor / grid-following current limit
            return False
        ev = vp.imag / math.sqrt(v.real * v.real + v.imag * v.imag)
        ji = jlf * i
        if mode[j] != GFL:  # remote / hd_visc: v_conv = vext, current-PI integrator frozen
            if iref and mode[j] == REMOTE:  # local loop on the received current reference
                ih = ihold[j]
                vc = v + zf * ih + kpc * (ih - i)
            else:
                vc = vext[j]
            gr = vc - v - ji
            e = 0j
        else:
            e = complex(SL[SREF_RE, j] / vd, SL[SREF_IM, j] / vd) - i * rc
            gr = (kpc * e + kic * X[XI * n + j]) * rc.conjugate()
            vc = v + ji + gr
        vdc = math.sqrt(max(X[W * n + j].real, 1e-4))
        vm = math.sqrt(vc.real * vc.real + vc.imag * vc.imag)
        if vm - mmax * vdc > 0.0:  # modulation limit
            return False
        edc = vdcref - vdc
        pme = kpdc * edc + X[XD * n + j].real
        if pme - SL[PAV, j] > 0.0 or pmemin - pme > 0.0 or vdc - vchop > 0.0:  # MSC clip, chopper
            return False
        pconv = vc.real * i.real + vc.imag * i.imag
        dX[IF * n + j] = complex(w0lf * gr.real - w0lfrf * i.real, w0lf * gr.imag - w0lfrf * i.imag)
        dX[XI * n + j] = e
        dX[TH * n + j] = w0kp * ev + OMEGA0 * xp
        dX[XP * n + j] = kipll * ev
        dX[W * n + j] = two_tdc * pme - two_tdc * pconv
        dX[XD * n + j] = kidc * edc
        dX[WR * n + j] = SL[PAH, j] - pme * SL[INV2HW, j]
        dX[B * n + j] = SL[DB, j]
        dX[XB * n + j] = SL[DXB, j]
        if want:
            A[0, j] = v.real
            A[1, j] = v.imag
            A[2, j] = i.real
            A[3, j] = i.imag
            A[4, j] = v.real * i.real + v.imag * i.imag
            A[5, j] = v.imag * i.real - v.real * i.imag
            A[A_VDC, j] = vdc
            A[A_OM, j] = (kppll * ev + xp) + 1.0
            A[A_PME, j] = pme
            A[A_VC_RE, j] = vc.real
            A[A_VC_IM, j] = vc.imag
    # ---------------------------------------------------------------- condenser, grid, PCC PLL
    vp = complex(vr[n], vi[n])
    vsc = complex(vr[n + 1], vi[n + 1])
    if scon:
        delta, w, eq1, eq2 = X[o + DELTA].real, X[o + OMEGA].real, X[o + EQ1].real, X[o + EQ2].real
        ed2, xll, efd = X[o + ED2].real, X[o + XLL].real, X[o + EFD].real
        v_reg = abs(vp) if K[AVRPCC] != 0.0 else abs(vsc)
        i_sc = (e_sc - vsc) / complex(K[Z2_RE], K[Z2_IM])
        im = i_sc * 1j * cmath.exp(-1j * delta)
        i_d, i_q = im.real, im.imag
        u = K[VREF] - v_reg - K[MQ] * (vsc * i_sc.conjugate()).imag
        defd = (K[AVRK] * (K[TATB] * u + K[TA1] * xll) - efd) / K[TE]
        if (efd >= K[EFDMAX] and defd > 0) or (efd <= K[EFDMIN] and defd < 0):
            defd = 0.0
        dX[o + DELTA] = OMEGA0 * (w - 1.0)
        dX[o + OMEGA] = (-(ed2 * i_d + eq2 * i_q) - K[DSC] * (w - 1.0)) / K[H2]
        dX[o + EQ1] = (efd - eq1 - K[XDD1] * i_d) / K[TD01]
        dX[o + EQ2] = (eq1 - eq2 - K[XD12] * i_d) / K[TD02]
        dX[o + ED2] = (-ed2 + K[XQD2] * i_q) / K[TQ02]
        dX[o + XLL] = (u - xll) / K[TB]
        dX[o + EFD] = defd
    else:
        i_sc = 0j
        for k in range(SC_NX):
            dX[o + k] = 0j
    og = o + SC_NX
    if K[HG] > 0.0:
        wg, pm = X[og + 1].real, X[og + 2].real
        ig = (e_grid - vp) * complex(K[YG_RE], K[YG_IM])
        pe = (e_grid * ig.conjugate()).real * K[GSCALE]
        dX[og] = OMEGA0 * (wg - 1.0)
        dX[og + 1] = (pm - pe - K[DG] * (wg - 1.0)) / (2.0 * K[HG])
        dX[og + 2] = (K[PM0] - (wg - 1.0) / K[RGOV] - pm) / K[TGOV]
    else:
        dX[og] = 0j
        dX[og + 1] = 0j
        dX[og + 2] = 0j
    xpp = X[og + 4].real
    ev = (vp * cmath.exp(-1j * X[og + 3].real)).imag / max(abs(vp), 0.1)
    dX[og + 3] = OMEGA0 * (kppll * ev + xpp)
    dX[og + 4] = K[KIPLL] * ev
    if want:
        for r in range(m):
            Vr[r] = complex(vr[r], vi[r])
        Z[Z_ISC] = i_sc
        Z[Z_EG] = e_grid
        Z[Z_ESC] = e_sc
        Z[Z_ILOAD] = i_load
        Z[Z_FPCC] = 1.0 + kppll * ev + xpp
    return True


@njit(cache=True, error_model="numpy")
def evaluate(X, K, SL, mode, vext, ihold, ZP, cb, A):
    """One evaluation of X with its aux (the cached first stage of the next step) into the output
    buffer ``cb`` = [unused (size), dX (size), Vr (n + 2), Z (NZ)] and A; False: numpy path."""
    size = X.size
    s2 = 2 * size
    m = SL.shape[1] + 2
    return _rhs(X, K, SL, mode, vext, ihold, ZP, cb[size:s2], cb[s2:s2 + m], A, cb[s2 + m:], True)


@njit(cache=True, error_model="numpy")
def step(X, k1, ETD, K, SL, mode, vext, ihold, ZP, cb, A, do_eval):
    """Unrolled ETD2 step of Plant.step: a = X + phi1 k1, X+ = a + phi2 (k2 - E k1) into
    cb[:size] (ETD rows: E, phi1, phi2, real, each entry twice: the update runs on the real and
    imaginary parts as float arrays, the same products as numpy's with a zero imaginary part), then (``do_eval``) the evaluation of X+ into the rest
    of ``cb`` and A as ``evaluate``. Returns 0 (done), 1 (stage 2 needs the numpy path, nothing
    written) or 2 (X+ done, its evaluation needs the numpy path)."""
    size = X.size
    s2 = 2 * size
    m = SL.shape[1] + 2
    E = ETD[0]
    P1 = ETD[1]
    P2 = ETD[2]
    a = np.empty(size, dtype=np.complex128)
    k2 = np.empty(size, dtype=np.complex128)
    Vr = cb[s2:s2 + m]
    Z = cb[s2 + m:]
    af, k1f, k2f = a.view(np.float64), k1.view(np.float64), k2.view(np.float64)
    Xf = X.view(np.float64)
    for j in range(s2):
        af[j] = P1[j] * k1f[j] + Xf[j]
    if not _rhs(a, K, SL, mode, vext, ihold, ZP, k2, Vr, A, Z, False):
        return 1
    Xn = cb[:size]
    Xnf = Xn.view(np.float64)
    for j in range(s2):
        Xnf[j] = af[j] + (k2f[j] - E[j] * k1f[j]) * P2[j]
    if not do_eval:
        return 0
    if not _rhs(Xn, K, SL, mode, vext, ihold, ZP, cb[size:s2], Vr, A, Z, True):
        return 2
    return 0


@njit(cache=True, error_model="numpy")
def slow_terms(X, v_wind, mppt, p_cmd, q_cmd, KS, SO):
    """TurbineBank.slow_terms into SO: rows SREF_RE..PAV (the SL rows) and PAERO; returns
    (vd_ok, min(P_avail))."""
    n = v_wind.shape[0]
    vwr, lam_opt, cp_opt, pme_max, headroom = KS[0], KS[1], KS[2], KS[3], KS[4]
    wref, kpb, bmax, taub, rateb, kib, hr, imax = KS[5], KS[6], KS[7], KS[8], KS[9], KS[10], KS[11], KS[12]
    smax = 0.0
    pav_min = np.inf
    for j in range(n):
        wr = X[WR * n + j].real
        beta = X[B * n + j].real
        vr = v_wind[j] / vwr
        lam = lam_opt * max(wr, 0.05) / vr
        li = 1.0 / (lam + 0.08 * beta) - 0.035 / (beta ** 3 + 1.0)
        cp = 0.5176 * (116.0 * li - 0.4 * beta - 5.0) * math.exp(-21.0 * li) + 0.0068 * lam
        pa = max(cp, 0.0) / cp_opt * vr ** 3
        pav = min(pme_max, max(pa, 0.0) + headroom)
        ps = min(max(wr, 0.0) ** 3, 1.0) if mppt[j] else p_cmd[j]
        ew = wr - wref
        bref_u = kpb * ew + X[XB * n + j].real
        bref = max(min(bref_u, bmax), 0.0)
        aw_b = (bref_u <= 0.0 and ew < 0) or (bref_u >= bmax and ew > 0)
        inv2hw = 1.0 / (2.0 * hr * max(wr, 0.1))
        SO[SREF_RE, j] = ps
        SO[SREF_IM, j] = -q_cmd[j]
        SO[PAH, j] = pa * inv2hw
        SO[INV2HW, j] = inv2hw
        SO[DB, j] = max(min((bref - beta) / taub, rateb), -rateb)
        SO[DXB, j] = 0.0 if aw_b else kib * ew
        SO[PAV, j] = pav
        SO[PAERO, j] = pa
        smax = max(smax, math.sqrt(ps * ps + q_cmd[j] * q_cmd[j]))
        pav_min = min(pav_min, pav)
    return max(0.3, smax / imax), pav_min


class JitAux(dict):
    """aux of a compiled evaluation: the entries of ``FastRHS.rhs``'s aux, built on first access
    (``[]``) from the evaluation's output buffer ``cb`` (layout in ``evaluate``) and rows ``A``;
    the measurement dict is built at once (``Plant.measurements`` asks for it with ``get``)."""

    __slots__ = ("_src",)

    def __init__(self, cb, A, n, size, tb):
        o = 2 * size
        self["v_pcc"] = complex(cb[o + n])
        self["meas"] = dict(zip(MEAS_KEYS, A))  # rows 0-7 (Plant.measurements)
        self._src = (cb, A, n, o, tb)

    def __missing__(self, key):
        cb, A, n, o, tb = self._src
        if key == "v":
            val = cb[o:o + n]
        elif key == "Vr":
            val = cb[o:o + n + 2]
        elif key == "i":
            val = A[2] + 1j * A[3]
        elif key == "s":
            val = A[4] + 1j * A[5]
        elif key == "vconv":
            val = A[A_VC_RE] + 1j * A[A_VC_IM]
        elif key in _A_ROWS:
            val = A[_A_ROWS[key]]
        elif key == "v_sc":
            val = complex(cb[o + n + 1])
        elif key in _Z_KEYS:
            val = complex(cb[o + n + 2 + _Z_KEYS.index(key)])
        elif key == "f_pcc":
            val = cb[o + n + 2 + Z_FPCC].real
        elif key == "paero":
            val = tb.slow["paero"]
        elif key == "vlim":
            val = tb._false
        elif key in ("law_out", "pbatt"):
            val = None if key == "law_out" else 0.0
        else:
            raise KeyError(key)
        self[key] = val
        return val


_A_ROWS = {"vdc": A_VDC, "om": A_OM, "pme": A_PME}
_Z_KEYS = ("i_sc", "e_grid", "e_sc", "i_load")


class _Slow(dict):
    """``TurbineBank.slow_terms``'s dict from the compiled slow terms; P* - jQ* built on demand."""

    __slots__ = ("SO",)

    def __missing__(self, key):
        if key != "sref":
            raise KeyError(key)
        val = self["sref"] = self.SO[SREF_RE] + 1j * self.SO[SREF_IM]
        return val


class JitPath:
    """Packs the plant's values for the kernels and runs them when the usual case applies."""

    def __init__(self, plant):
        self.pl = plant
        self.n = n = plant.n
        self.size = plant.size
        tp = plant.params.turbine
        self.K = K = np.zeros(NK)
        K[KPC], K[KIC], K[LF] = tp.kpc, tp.kic, tp.lf
        K[W0LF] = OMEGA0 / tp.lf
        K[W0LFRF] = OMEGA0 / tp.lf * tp.rf
        K[W0KP], K[KIPLL], K[KPPLL] = OMEGA0 * tp.kp_pll, tp.ki_pll, tp.kp_pll
        K[MMAX], K[VDCREF], K[KPDC], K[RF] = tp.m_max, tp.v_dc_ref, tp.kp_dc, tp.rf
        K[TWO_TDC], K[KIDC], K[PMEMIN], K[VCHOP] = 2.0 / tp.tau_dc, tp.ki_dc, tp.p_me_min, tp.v_chop
        self.SL = np.zeros((NSL, n))
        self._sl = self._zsrc = self._etd_src = None
        _load_kernels()

    # ---------------------------------------------------------------- packing
    def hold_slow(self, _S=None) -> None:
        """``TurbineBank.hold_slow`` compiled: the slow terms into ``tb.slow`` (same dict) and SL."""
        pl, tb = self.pl, self.pl.tb
        p = tb.p
        KS = np.array([p.v_wind_rated, T.LAMBDA_OPT, T.CP_OPT, p.p_me_max, p.p_headroom, p.omega_r_ref,
                       p.kp_beta, p.beta_max, p.tau_beta, p.rate_beta, p.ki_beta, p.h_rotor, p.i_max_gfl])
        SO = np.empty((PAERO + 1, self.n))
        vd_ok, pav_min = slow_terms(pl.X, tb.v_wind, tb.mppt, tb.p_cmd, tb.q_cmd, KS, SO)
        tb.slow = sl = _Slow(paero=SO[PAERO], pav=SO[PAV], pav_min=pav_min, vd_ok=vd_ok, inv2hw=SO[INV2HW],
                             db=SO[DB], dxb=SO[DXB], any_batt=bool(tb.battery.any()))
        sl.SO = SO
        self.SL = SO[:NSL]
        self.K[VDOK] = vd_ok
        self._sync_values()
        self._sl = sl

    def _sync(self, sl) -> None:
        """Slow terms held by the numpy code (``TurbineBank.hold_slow``) into SL and K."""
        SL = self.SL = np.empty((NSL, self.n))
        SL[SREF_RE] = sl["sref"].real
        SL[SREF_IM] = sl["sref"].imag
        np.multiply(sl["paero"], sl["inv2hw"], out=SL[PAH])
        SL[INV2HW] = sl["inv2hw"]
        SL[DB] = sl["db"]
        SL[DXB] = sl["dxb"]
        SL[PAV] = sl["pav"]
        self.K[VDOK] = sl["vd_ok"]
        self._sync_values()
        self._sl = sl

    def _sync_values(self) -> None:
        """The present grid/condenser/load values into K (with every slow evaluation)."""
        pl, K = self.pl, self.K
        net, g, sc = pl.net, pl.params.grid, pl.sc
        p = sc.p
        yg, ysc, load = complex(net.y_grid), complex(net.y_sc), pl.load_s
        K[EG:VL_RE] = (g.e_grid, yg.real, yg.imag, ysc.real, ysc.imag, load.real, load.imag)
        hg = g.h_grid > 0
        K[SCON:PM0 + 1] = (1.0 if net.sc_connected else 0.0, 1.0 if p.avr_bus == "pcc" else 0.0, sc.v_ref,
                    sc.z2.real, sc.z2.imag, p.m_q, p.avr_k, p.avr_ta_tb, 1.0 - p.avr_ta_tb, p.avr_te,
                    p.efd_max, p.efd_min, 2.0 * p.h, p.d, p.xd - p.xd1, p.xd1 - p.xd2, p.xq - p.xd2,
                    p.td01, p.td02, p.tq02, p.avr_tb, g.h_grid, g.s_base_mva / g.s_grid_mva if hg else 0.0,
                    g.d_grid if hg else 0.0, g.r_gov if hg else 1.0, g.t_gov if hg else 1.0, pl.pm0)
        K[IREF] = 1.0 if pl.params.turbine.remote_apply == "i_ref" else 0.0

    def _ready(self) -> bool:
        """Pack what changed; False if the compiled path does not cover the present case."""
        pl = self.pl
        sl = pl.tb.slow
        if sl is None or sl["any_batt"] or pl.xl is not None or pl.visc_idx.size or not pl.net.all_plugged:
            return False
        if sl is not self._sl:
            self._sync(sl)
        zred = pl.net.zred
        if zred is not self._zsrc:
            self.ZP = np.ascontiguousarray(np.stack([zred.real.T, zred.imag.T]))
            self._zsrc = zred
        v = pl._v_pcc_last
        self.K[VL_RE] = v.real
        self.K[VL_IM] = v.imag
        return True

    # ---------------------------------------------------------------- entry points
    def evaluate(self):
        """(dX, None, aux) of the present state as ``Plant._rhs(X, xl, want_aux=True)``, or None."""
        if not self._ready():
            return None
        pl, size, n = self.pl, self.size, self.n
        tb = pl.tb
        cb = np.empty(2 * size + n + 2 + NZ, dtype=complex)
        A = np.empty((NA, n))
        if not evaluate(pl.X, self.K, self.SL, tb.mode, tb.v_hold, tb.i_hold, self.ZP, cb, A):
            return None
        return cb[size:2 * size], None, JitAux(cb, A, n, size, pl.tb)

    def step(self, k1, etd) -> bool:
        """One ETD2 step (Plant.step, usual case); False: nothing done, the numpy code runs it."""
        if not self._ready():
            return False
        pl, size, n = self.pl, self.size, self.n
        tb = pl.tb
        if etd[0] is not self._etd_src:  # (E, phi1, phi2) of Plant._etd_coeffs, cached there
            self.ETD = np.repeat(np.stack(etd).real, 2, axis=1)  # (3, 2 size): re, im of each entry
            self._etd_src = etd[0]
        do_eval = pl.k + 1 < pl._slow_next  # else the slow terms are re-evaluated at X+ first
        cb = np.empty(2 * size + n + 2 + NZ, dtype=complex)
        A = np.empty((NA, n))
        code = step(pl.X, k1, self.ETD, self.K, self.SL, tb.mode, tb.v_hold, tb.i_hold, self.ZP, cb, A, do_eval)
        if code == 1:
            return False
        if code == 2 or not do_eval:
            pl._advance(cb[:size], None)
            return True
        # Plant._advance with the evaluation done
        pl.X = cb[:size]
        pl.k += 1
        pl._slow_keep = False
        aux = JitAux(cb, A, n, size, tb)
        pl._cache = (cb[size:2 * size], None, aux)
        pl._v_pcc_last = aux["v_pcc"]
        return True


_loaded = False


def _load_kernels() -> None:
    """Call every kernel once on a one-turbine dummy (argument types as in a run), so that numba
    loads them from its cache (or compiles them) when a plant is built, not in its first step."""
    global _loaded
    if _loaded:
        return
    size = NS + SC_NX + 5
    X, K, SL = np.ones(size, dtype=complex), np.ones(NK), np.ones((NSL, 1))
    mode, vext, ZP = np.zeros(1, dtype=int), np.ones(1, dtype=complex), np.ones((2, 3, 3))
    cb, A = np.empty(2 * size + 3 + NZ, dtype=complex), np.empty((NA, 1))
    evaluate(X, K, SL, mode, vext, vext, ZP, cb, A)
    step(X, cb[size:2 * size], np.ones((3, 2 * size)), K, SL, mode, vext, vext, ZP, cb, A, True)
    slow_terms(X, np.ones(1), np.ones(1, dtype=bool), np.ones(1), np.ones(1), np.ones(13), np.empty((PAERO + 1, 1)))
    _loaded = True


def warm_up(params=None, step_s: float = 0.67e-3) -> None:
    """Run the code paths of a real-time run once on a 2-turbine scratch plant (``params``):
    remote references every step, a fault on and off, back to grid following. numba compiles each
    kernel (or loads it from its cache: tens of ms each) at its first call; the plant service calls
    this before t = 0, not at the first CTRL packet (a 45 ms stall of the paced loop, measured)."""
    from plant.sim import Plant  # noqa: PLC0415

    p = Plant(params, n_turbines=2, step_s=step_s)
    p.set_mode([1], "remote")
    for k in range(30):
        if k in (10, 20):
            p.fault(k == 10)
        m = p.measurements()
        p.apply_remote([1], m["v_d"][1:], m["v_q"][1:], m["i_d"][1:], m["i_q"][1:])
        p.step()
        if k % 5 == 0:
            p.outputs()
    p.set_mode([1], "grid_following")
    for _ in range(3):
        p.step()
        p.measurements()


def precompile() -> None:
    """Fill numba's on-disk cache for both remote-apply variants, so that a plant started in a run
    does not spend seconds compiling (``./testbed`` and the Docker image call this)."""
    from dataclasses import replace  # noqa: PLC0415

    from plant.params import PlantParams  # noqa: PLC0415

    base = PlantParams()
    for apply in ("v_ref", "i_ref"):
        warm_up(replace(base, turbine=replace(base.turbine, remote_apply=apply)))
