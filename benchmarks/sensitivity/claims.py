"""The printed numbers the study varies, each read as its report experiment reads it, and the groups of
runs they share (several claims read one evaluation: F7.a/b/c, F8.a/c, F9.c/d)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from benchmarks.sensitivity import ranges, structure
from benchmarks.sensitivity.c1 import eval_c1
from benchmarks.sensitivity.common import rel
from benchmarks.sensitivity.faults import READINGS, eval_f6d, eval_f8
from benchmarks.sensitivity.weak import eval_f7, eval_f9
from report.verdicts import change_close_to, close_to

GROUPS = {  # name -> (evaluation, parameter ranges and open values, structural alternatives)
    "F6.d": (eval_f6d, ranges.F6D_PARAMS, ()),
    "F7": (eval_f7, ranges.F7_PARAMS, structure.F7_STRUCTURE),
    "F8": (eval_f8, ranges.F8_PARAMS, ()),
    "F9": (eval_f9, ranges.F9_PARAMS, structure.F9_STRUCTURE),
    "C1.b": (eval_c1, ranges.C1_PARAMS, ()),
}
ALIASES = {"F7.b": "F7"}  # the group's name before issue 39


@dataclass(frozen=True)
class Claim:
    id: str
    text: str
    paper: float
    unit: str
    group: str
    value: Callable  # result -> the judged number (None: does not happen)
    judge: Callable  # (number, result) -> "yes" / "partly" / "no" (the report's rule)
    towards: Callable  # result -> distance to the paper (smaller = closer; for the corner)
    measures: Callable | None = None  # result -> [(row name, {label: value}, source)]: other readings of the run
    detail: Callable | None = None  # result -> a word on the value (F7: the mechanism of the loss)
    band: bool = True  # the paper's number is a magnitude (±10 % shaded); False: an ordering


def _get(r, *keys):
    for k in keys:
        if r is None:
            return None
        r = r.get(k)
    return r


def _matrix_rows(target: float) -> Callable:
    """The fault matrix of a run as rows: per bus and reading, its value for every type x resistance."""
    def rows(r: dict) -> list:
        m = r.get("matrix")
        if not m:
            return []
        out = []
        for bus in ("terminal", "pcc"):
            for key in READINGS:
                vals = {f"{kind.upper()} {ohm} Ω": m[kind][ohm][bus][key] for kind in structure.FAULT_KINDS
                        for ohm in m[kind]}
                rf = _get(m, "r_f_for_paper")
                extra = "" if not rf else f"; R_f for {target:g}: " + ", ".join(
                    f"{kind.upper()} {'none ≤ 50 Ω' if rf[kind][bus][key] is None else f'{rf[kind][bus][key]:.1f} Ω'}"
                    for kind in structure.FAULT_KINDS)
                out.append((f"{bus} {key.replace('_', ' ')}", vals,
                            f"{structure.FAULT_KIND_SOURCE}; {structure.R_F_SOURCE}; {structure.READING_SOURCE}{extra}"))
        return out
    return rows


def _f7(case: str, paper: float, text: str, claim: str) -> Claim:
    return Claim(claim, text, paper, "SCR", "F7", lambda r: r["boundaries"][case],
                 lambda x, r: "no" if x is None else close_to(x, paper), lambda r: rel(r["boundaries"][case], paper),
                 detail=lambda r: _get(r, case, "below", "mechanism"))


def _lower(x, r) -> str:
    sc = r["boundaries"]["SC"]
    return "yes" if x is not None and (sc is None or x < sc) else "no"


CLAIMS = (
    Claim("F6.d", "SLG fault: the SDViSC's residual voltage is about 0.6 p.u. (report F6.d: its own terminal, "
          "positive sequence, SLG bolted)", 0.6, "p.u.", "F6.d", lambda r: r["terminal V1"],
          lambda x, r: close_to(x, 0.6), lambda r: rel(r["terminal V1"], 0.6), _matrix_rows(0.6)),
    _f7("none", 2.04, "without SC or SDViSC the farm loses stability when the SCR decreases to 2.04", "F7.a"),
    _f7("SC", 1.58, "with the SC the farm loses stability when the SCR decreases to 1.58", "F7.b"),
    Claim("F7.c", "with the SDViSC the farm is stable at a still lower SCR than with the SC (yes = its boundary below "
          "the SC's of the same run; the line: the paper's SC 1.58)", 1.58, "SCR", "F7",
          lambda r: r["boundaries"]["SDViSC"], _lower,
          lambda r: (r["boundaries"]["SDViSC"] - r["boundaries"]["SC"]) if None not in
          (r["boundaries"]["SDViSC"], r["boundaries"]["SC"]) else float("inf"),
          detail=lambda r: _get(r, "SDViSC", "below", "mechanism"), band=False),
    Claim("F8.a", "4 SDViSCs activated at 1 s raise V_pcc from 0.97 to 1.02 p.u. (judged on the rise, +0.05)", 0.05,
          "p.u.", "F8", lambda r: r["rise"],
          lambda x, r: "no" if x is None else change_close_to(0.97, 0.97 + x, 0.97, 1.02), lambda r: rel(r["rise"], 0.05)),
    Claim("F8.c", "without SDViSCs V_pcc drops to 0.4 p.u. during the phase-to-ground fault (report F8.c: the PCC's "
          "faulted phase RMS, SLG; bolted here, the resistance in the matrix rows)", 0.4, "p.u.", "F8",
          lambda r: _get(r, "fault", "faulted_phase"), lambda x, r: "no" if x is None else close_to(x, 0.4),
          lambda r: rel(_get(r, "fault", "faulted_phase"), 0.4), _matrix_rows(0.4)),
    Claim("F9.d", "SCR 7.14 -> 1.51 with 3 SDViSCs: stable until ~3 s, then leaves the nominal point (report F9.d: "
          "WT1_CS1's terminal leaves 0.9-1.1 for good)", 3.0, "s", "F9", lambda r: r["t_away_wt1_3"],
          lambda x, r: "no" if x is None else close_to(x, 3.0), lambda r: rel(r["t_away_wt1_3"], 3.0),
          lambda r: [("read at the PCC", {"PCC": r["t_away_pcc_3"]}, "docs/report.md before issue 39 read the PCC; "
                      "the caption names WT1_CS1")],
          detail=lambda r: r["state_3"]),
    Claim("F9.c", "SDViSCs needed at SCR 1.51: 4 (3 are not enough)", 4.0, "SDViSCs", "F9", lambda r: r["n_stable"],
          lambda x, r: "no" if x is None else close_to(x, 4.0), lambda r: rel(r["n_stable"], 4.0),
          detail=lambda r: f"3: {r['state_3']}"),
    Claim("C1.b", "a plugged SDViSC's currents and voltages settle within ~0.1 s (offline analogue: continuous law, "
          "no network)", 0.1, "s", "C1.b", lambda r: r["settle band 0.02"], lambda x, r: close_to(x, 0.1),
          lambda r: rel(r["settle band 0.02"], 0.1),
          lambda r: [("band 0.05 p.u.", {"band 0.05 p.u.": r["settle band 0.05"]}, "the settling band is not stated")]),
)
