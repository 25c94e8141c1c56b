"""Vectorised PMSG full-converter turbines (p.u. on the turbine rating, common frame at OMEGA0).

State of every turbine (rows of one complex array ``S`` of shape (NS, N); rows flagged real keep
a zero imaginary part)::

    IF   filter-inductor current i = i_d + j i_q (complex, converter -> grid positive)
    XI   current-PI integrator, PLL frame (complex)
    TH   PLL angle theta versus the common frame, rad
    XP   PLL integrator (frequency deviation), p.u.
    W    DC-link w = v_dc^2, p.u.
    XD   machine-side DC-voltage PI integrator, p.u. power
    WR   rotor speed, p.u.
    B    pitch angle, deg
    XB   pitch PI integrator, deg
    VM   measured terminal voltage |v| (first-order filter t_ufilt), p.u.
    AD   active damping's low-pass of the terminal voltage phi (complex, common frame), p.u.

Equations (t in s, w0 = OMEGA0):

    (lf/w0) di/dt = v_conv - v - (rf + j lf) i                  filter in the common frame
    v_conv limited to |v_conv| <= m_max v_dc                     average model, DC-limited
    grid-following (PLL frame, rot = e^{j theta}):
        e_v = Im(v e^{-j theta}) / max(|v|, 0.1),  dtheta/dt = w0 (kp_pll e_v + x_p), dx_p/dt = ki_pll e_v
        t_ufilt dV_m/dt = |v| - V_m                                 voltage measurement (IEC 61400-27-1)
        i* = (P* - j Q*) / max(V_m, 0.3)  (circular limit i_max_gfl; FRT on V_m),  e = i* - i e^{-j theta}
        P* = min(w_r^3, 1) (MPPT curve: optimal tip-speed ratio below rated) or a commanded value
        v_conv = v + j lf i + (kpc e + kic xi) e^{j theta} - k_ad (v - phi),  dxi/dt = e  (frozen while DC-limited)
        dphi/dt = w_ad (v - phi)                                    active damping (D'Arco 2015)
    hd_visc: v_conv = sdc_unit.law.outputs(x, meas).v_ref (law states integrated by the plant)
    remote:  v_conv = last received reference (held)
    DC link: (tau_dc/2) d(v_dc^2)/dt = P_me + P_batt - P_conv - P_chop,  P_conv = Re(v_conv conj(i))
             P_chop = min(k_chop max(v_dc - v_chop, 0), 1.5)   (braking chopper)
    MSC:     P_me = clip(kp_dc (v_dc* - v_dc) + x_d, p_me_min, P_avail), dx_d/dt = ki_dc (v_dc* - v_dc)
             (the MSC current loop is taken as ideal: i_sd* from the PI, i_sq* = 0, so P_me follows)
    battery: P_batt = v_dc i_b, i_b from OCV(SOC), resistance and limits (plant/battery.py; only where enabled)
    rotor (single mass, stiff shaft, rotor+generator inertia lumped):
             2 h_rotor w_r dw_r/dt = P_aero - P_me
    aero:    P_aero = (Cp(lambda, beta)/Cp_opt) (v_w / v_rated)^3,  lambda = lambda_opt w_r v_rated / v_w
             Cp: Heier/Slootweg formula; P_avail = min(p_me_max, max(P_aero, 0) + p_headroom)
             (the MSC may draw the present aerodynamic power plus a small kinetic-energy headroom)
    pitch:   beta* = clip(kp_b (w_r - w_ref) + x_b, 0, beta_max), dx_b/dt = ki_b (w_r - w_ref),
             dbeta/dt = clip((beta* - beta)/tau_b, -rate, rate)

``rhs`` is the general numpy implementation (the reference of the compiled kernels,
plant/turbine_kernels.py); results are written into the caller's derivative array. The limiters
(V_d floor and current limit, modulation limit, MSC power clip, chopper) and the battery current
are written once, in plant/turbine_laws.py, for both.
The slow terms (P_aero, P_avail, P* - jQ*, 1/(2 H w_r), dbeta/dt, dx_b/dt) come from
``slow_terms`` and are held by the plant over ``Plant.slow_every`` steps (``self.slow``).
"""

from __future__ import annotations

import numpy as np

from plant import turbine_laws as laws
from plant.battery import BatteryBank
from plant.params import BatteryParams, TurbineParams
from sdvisc.vocabulary import OMEGA0

IF, XI, TH, XP, W, XD, WR, B, XB, VM, AD = range(11)
NS = 11

GFL, HD_VISC, REMOTE = 0, 1, 2
MODES = {"grid_following": GFL, "hd_visc": HD_VISC, "remote": REMOTE}
MODE_NAMES = {v: k for k, v in MODES.items()}


def _complex(re, im):
    """The complex array re + j im."""
    z = np.empty(np.shape(re), dtype=complex)
    z.real = re
    z.imag = im
    return z


def cp_heier(lam, beta):
    """Power coefficient (Heier / Slootweg), beta in degrees."""
    li = 1.0 / (lam + 0.08 * beta) - 0.035 / (beta**3 + 1.0)
    return 0.5176 * (116.0 * li - 0.4 * beta - 5.0) * np.exp(-21.0 * li) + 0.0068 * lam


_LAM = np.linspace(2.0, 14.0, 12001)
_CPS = cp_heier(_LAM, 0.0)
LAMBDA_OPT = float(_LAM[np.argmax(_CPS)])
CP_OPT = float(np.max(_CPS))


class TurbineBank:
    """Parameters, modes and the right-hand side of N turbines."""

    def __init__(self, params: TurbineParams, n: int, v_wind: float, battery: BatteryParams | None = None,
                 rating_mva=None):
        self.p = params
        self.n = n
        self.v_wind = np.full(n, float(v_wind))
        self.mode = np.zeros(n, dtype=int)
        self.battery = np.zeros(n, dtype=bool)  # battery connected (set_battery)
        self.batt = BatteryBank(battery or BatteryParams(), params, n, rating_mva)  # rating: each converter's own
        self.q_cmd = np.zeros(n)  # local Q* (set_power_ref)
        self.q_wpp = np.zeros(n)  # Q* added by the plant-level voltage controller (plant/wpp.py)
        self.p_cmd = np.zeros(n)
        self.mppt = np.ones(n, dtype=bool)  # grid-following P* from the MPPT curve (else p_cmd)
        self.v_hold = np.zeros(n, dtype=complex)  # the remote v_ref applied (the SDC's, or the local limit's)
        self.v_sdc = np.zeros(n, dtype=complex)  # the last v_ref received (Commands._local_current_limit)
        self.i_hold = np.zeros(n, dtype=complex)
        self.last_rx_step = np.zeros(n, dtype=np.int64)
        self.fallback_enabled = True
        # the converters' active damping also under hd_visc/remote references, with either network model
        # (TurbineParams.ext_active_damping; issue 39 item 10: it was the dynamic-phasor network's only)
        self.ext_active_damping = bool(params.ext_active_damping)
        self.fell_back = np.zeros(n, dtype=bool)
        self.fallbacks = np.zeros(n, dtype=np.int64)
        self.trips = np.zeros(n, dtype=np.int64)
        self.slow = None  # slow terms held over one plant step (slow_terms), or None = every stage

    def hold_slow(self, S) -> None:
        """Evaluate the slow (mechanical) terms once per plant step (zero-order hold; rotor/pitch act
        in seconds): aerodynamic power, MSC power limit, the grid-following power reference
        (MPPT curve), 1/(2 H w_r) and the pitch derivatives."""
        self.slow = self.slow_terms(S)

    def slow_terms(self, S):
        p = self.p
        Sr = S.real
        wr, beta = Sr[WR], Sr[B]
        pa = self.p_aero(wr, beta)
        pav = self.p_avail(pa)
        sref = self.p_star(wr) - 1j * (self.q_cmd + self.q_wpp)
        ew = wr - p.omega_r_ref
        bref_u = p.kp_beta * ew + Sr[XB]
        bref = np.maximum(np.minimum(bref_u, p.beta_max), 0.0)
        aw_b = ((bref_u <= 0.0) & (ew < 0)) | ((bref_u >= p.beta_max) & (ew > 0))
        db = np.maximum(np.minimum((bref - beta) / p.tau_beta, p.rate_beta), -p.rate_beta)
        dxb = np.where(aw_b, 0.0, p.ki_beta * ew)
        inv2hw = 1.0 / (2.0 * p.h_rotor * np.maximum(wr, 0.1))
        return {"paero": pa, "pav": pav, "sref": sref, "inv2hw": inv2hw, "db": db, "dxb": dxb,
                "any_batt": bool(self.battery.any())}

    # ------------------------------------------------------------------ aero
    def p_aero(self, wr, beta):
        vr = self.v_wind / self.p.v_wind_rated
        lam = LAMBDA_OPT * np.maximum(wr, 0.05) / vr
        return np.maximum(cp_heier(lam, beta), 0.0) / CP_OPT * vr**3

    def p_avail(self, paero):
        """Upper limit of the machine-side power: present aero power + kinetic headroom, <= rating."""
        return np.minimum(self.p.p_me_max, np.maximum(paero, 0.0) + self.p.p_headroom)

    def wr0(self):
        return np.minimum(self.p.omega_r_ref, self.v_wind / self.p.v_wind_rated)

    def p_star(self, wr):
        """Grid-following active-power reference: MPPT curve P = min(w_r^3, 1) or the command."""
        mp = np.minimum(np.maximum(wr, 0.0) ** 3, 1.0)
        return mp if self.mppt.all() else np.where(self.mppt, mp, self.p_cmd)

    # ------------------------------------------------------------------ controls
    def gfl_vconv(self, S, v):
        """Grid-following converter voltage (not modulation-limited) and PLL error."""
        p = self.p
        i = S[IF]
        rot = np.exp(1j * S[TH].real)
        vp = v * rot.conj()
        ev = laws.pll_error(vp.imag, v.real, v.imag)
        vdc = np.sqrt(np.maximum(S[W].real, 1e-4))
        # the grid side's P* (grid-following: it holds the DC link); the machine side's terms unused here
        p_gsc = laws.dc_link_control(1.0, vdc, S[XD].real, 0.0, 0.0, p.v_dc_ref, p.kp_dc, p.ki_dc, p.p_me_min,
                                     p.p_me_max)[0]
        q_star = self.q_cmd + self.q_wpp
        e = _complex(*laws.gfl_current_ref(p_gsc, -q_star, S[VM].real, p.i_max_gfl, p.frt_v_dip,
                                            p.frt_k_qv)) - i * rot.conj()
        vconv = v + 1j * p.lf * i + (p.kpc * e + p.kic * S[XI]) * rot - p.k_ad * (v - S[AD])
        return vconv, e, ev

    def pll_error(self, S, v):
        vp = v * np.exp(-1j * S[TH].real)
        return laws.pll_error(vp.imag, v.real, v.imag)

    # ------------------------------------------------------------------ rhs
    def rhs(self, S, v, vconv_ext, ext_mask, any_ext=None, out=None):
        """Derivatives of S given terminal voltage v (turbine p.u.) and external converter refs.

        ``vconv_ext`` holds the converter voltage for turbines where ``ext_mask`` is True
        (remote and hd_visc); the others run grid-following.  Returns (dS, aux); ``out`` (NS, N)
        receives dS if given.  The limiters (V_d floor, current limit, modulation limit, MSC power
        clip, chopper) and the battery current are those of plant/turbine_laws.py.
        """
        p = self.p
        sl = self.slow if self.slow is not None else self.slow_terms(S)
        if any_ext is None:
            any_ext = bool(ext_mask.any())
        vconv, d, e, ev, lim, vdc, dc = self._grid_side(S, v, vconv_ext, ext_mask, any_ext, sl)
        i = S[IF]
        pconv = (vconv * i.conj()).real
        pme, dxd, p_dc, pbatt, ibatt = self._machine_side(S, vdc, pconv, sl, dc)
        dS = np.empty_like(S) if out is None else out
        dSr = dS.real
        dS.imag[TH:AD] = 0.0  # real rows
        d -= complex(p.rf, p.lf) * i  # v_conv - v - (rf + j lf) i
        np.multiply(d, OMEGA0 / p.lf, out=dS[IF])
        dS[XI] = np.where(lim | ext_mask, 0.0, e)  # frozen while modulation-limited
        np.multiply(ev, OMEGA0 * p.kp_pll, out=dSr[TH])
        dSr[TH] += OMEGA0 * S.real[XP]
        np.multiply(ev, p.ki_pll, out=dSr[XP])
        np.multiply(p_dc, 2.0 / p.tau_dc, out=dSr[W])
        dSr[XD] = dxd
        np.multiply(sl["paero"] - pme, sl["inv2hw"], out=dSr[WR])
        dSr[B] = sl["db"]
        dSr[XB] = sl["dxb"]
        dSr[VM] = (np.abs(v) - S.real[VM]) / p.t_ufilt
        np.multiply(v - S[AD], p.w_ad, out=dS[AD])
        aux = {"vconv": vconv, "vdc": vdc, "pme": pme, "pbatt": pbatt, "ibatt": ibatt, "paero": sl["paero"],
               "vlim": lim, "ev": ev}
        return dS, aux

    def _grid_side(self, S, v, vconv_ext, ext_mask, any_ext, sl):
        """Grid-side converter: (v_conv, v_conv - v, current-loop error e (PLL frame), PLL error e_v,
        modulation-limited mask, v_dc)."""
        p = self.p
        i = S[IF]
        rotc = np.empty(self.n, dtype=complex)  # e^{-j theta}: cos and sin are cheaper than complex exp
        np.cos(S.real[TH], out=rotc.real)
        np.sin(S.real[TH], out=rotc.imag)
        np.negative(rotc.imag, out=rotc.imag)
        vp = v * rotc
        ev = laws.pll_error(vp.imag, v.real, v.imag)
        vdc = np.sqrt(np.maximum(S.real[W], 1e-4))
        dc = self.dc_control(S, vdc, sl)
        e = _complex(*laws.gfl_current_ref(dc[0], sl["sref"].imag, S.real[VM], p.i_max_gfl, p.frt_v_dip, p.frt_k_qv))
        e -= i * rotc
        # d = v_conv - v; grid-following: j lf i + (kpc e + kic xi) e^{j theta}
        d = p.kpc * e
        d += p.kic * S[XI]
        d *= rotc.conj()
        d += 1j * p.lf * i
        damping = p.k_ad * (v - S[AD]) if p.k_ad else 0.0
        d -= damping
        if any_ext:
            ext = vconv_ext - v
            if self.ext_active_damping:  # the converter's own active damping under a ViSC's reference
                ext = ext - damping
            d = np.where(ext_mask, ext, d)
        vconv = v + d
        vc_re, vc_im, lim = laws.modulation_limit(vconv.real, vconv.imag, vdc, p.m_max)
        if lim.any():
            vconv = _complex(vc_re, vc_im)
            d = vconv - v
        return vconv, d, e, ev, lim, vdc, dc

    def dc_control(self, S, vdc, sl):
        """(P*_gsc, P_me, dx_d/dt): the grid side holds the DC link when grid-following, else the
        machine side (``turbine_laws.dc_link_control``)."""
        p = self.p
        return laws.dc_link_control((self.mode == GFL) * 1.0, vdc, S.real[XD], sl["sref"].real, sl["pav"],
                                    p.v_dc_ref, p.kp_dc, p.ki_dc, p.p_me_min, p.p_me_max)

    def _machine_side(self, S, vdc, pconv, sl, dc):
        """The machine side (``dc``: dc_control's result), battery and chopper: (P_me, dx_d/dt, net power
        into the DC link, P_batt, battery current i_b)."""
        p = self.p
        _, pme, dxd = dc
        pbatt = ibatt = 0.0
        if sl["any_batt"]:
            ibatt = self.batt.current(vdc, self.battery)
            pbatt = vdc * ibatt
        p_dc = laws.dc_link_power(pme, pconv, pbatt, vdc, p.v_chop, p.k_chop)
        return pme, dxd, p_dc, pbatt, ibatt

    # ------------------------------------------------------------------ initialisation
    def init_state(self, v, i):
        """Steady state for grid-following operation at terminal voltage v and current i."""
        p = self.p
        n = self.n
        S = np.zeros((NS, n), dtype=complex)
        S[IF] = i
        th = np.angle(v)
        S[TH] = th
        vconv = v + (p.rf + 1j * p.lf) * i
        S[XI] = p.rf * i * np.exp(-1j * th) / p.kic
        S[W] = p.v_dc_ref**2
        pconv = (vconv * i.conj()).real  # = P_me: the machine side follows it, the DC link in balance
        S[XD] = (v * i.conj()).real  # the grid side's DC-voltage PI: P* = the terminal power at v_dc = 1
        wr0 = self.wr0()
        S[WR] = wr0
        # pitch: bisection for P_aero(1, beta) = pconv (beta >= 0)
        lo, hi = np.zeros(n), np.full(n, p.beta_max)
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            too_much = self.p_aero(wr0, mid) > pconv
            lo = np.where(too_much, mid, lo)
            hi = np.where(too_much, hi, mid)
        beta = np.where(self.p_aero(wr0, 0.0) > pconv, 0.5 * (lo + hi), 0.0)
        S[B] = beta
        S[XB] = beta
        S[VM] = np.abs(v)
        S[AD] = v
        return S

    def bumpless_gfl(self, S, v, idx, vconv_now):
        """Switch turbines idx to grid-following keeping v_conv continuous (P* = present P, Q* = 0; the
        grid side takes over the DC link from the machine side, which then follows P* = present P)."""
        p = self.p
        i = S[IF, idx]
        s_now = v[idx] * i.conj()
        self.p_cmd[idx] = s_now.real
        self.mppt[idx] = False
        self.q_cmd[idx] = 0.0
        self.mode[idx] = GFL
        # the grid side takes over the DC link: its PI's integrator set so that P*_gsc = the present P
        vdc = np.sqrt(np.maximum(S[W, idx].real, 1e-4))
        S[XD, idx] = s_now.real - p.kp_dc * (vdc - p.v_dc_ref)
        vconv_gfl, e, _ = self.gfl_vconv(S, v)
        rot = np.exp(1j * S[TH, idx].real)
        damping = p.k_ad * (v[idx] - S[AD, idx])
        S[XI, idx] = ((vconv_now - v[idx] - 1j * p.lf * i + damping) * rot.conj() - p.kpc * e[idx]) / p.kic
