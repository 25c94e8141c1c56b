"""The SDC's laws as a registry (issue 41): every list of run-time parameters is the one the wire
declares (sdvisc.wire_layouts.RUNTIME_PARAM_WORDS), every law's parameters are declared with a unit
and a source, and the generic trapezoid discretisation reproduces the ViSC's hand-derived Tustin
engine."""

from __future__ import annotations

import ast
from pathlib import Path
from types import SimpleNamespace
from typing import get_args

import numpy as np
import pytest

from sdc_unit import admission
from sdc_unit.bank import ControllerBank
from sdc_unit.discrete import DiscreteVisc
from sdc_unit.law_trapezoid import TrapezoidControllers
from sdc_unit.laws import LAWS, get_law
from sdc_unit.params import RUNTIME_PARAMS, ViscParams
from sdc_unit.tustin_jit import REF_ROWS
from sdvisc import vocabulary, wire
from sdvisc.wire_layouts import RUNTIME_PARAM_WORDS

ROOT = Path(__file__).resolve().parents[2]
WIRE_NAMES = tuple(p.name for p in RUNTIME_PARAM_WORDS)
OP = {"v_d": 1.0, "v_q": 0.02, "i_d": 0.5, "i_q": -0.1, "p": 0.5, "q": 0.1, "v_dc": 1.0, "omega_meas": 1.0}


def test_every_generated_list_of_runtime_parameters_is_the_wires():
    from host_tools.fuzz import PARAM_TEMPLATE
    from scenarios.schema import RuntimeParamName

    request_words = [f.name for f in wire.LAYOUTS[wire.MsgType.REQUEST]]
    lists = {
        "ParamMask": tuple(m.name.lower() for m in wire.ParamMask),
        "REQUEST words": tuple(request_words[request_words.index("mask") + 1:]),
        "VISC_PARAMS": tuple(vocabulary.VISC_PARAMS),
        "REQUEST_PARAM_WORDS": vocabulary.REQUEST_PARAM_WORDS[1:],
        "BLANK_REQUEST_PARAMS": tuple(k for k in vocabulary.BLANK_REQUEST_PARAMS if k != "mask"),
        "sdc_unit.params.RUNTIME_PARAMS": RUNTIME_PARAMS,
        "the ViSC law's run-time parameters": tuple(sorted(LAWS["visc"].runtime_params, key=WIRE_NAMES.index)),
        "scenarios.schema.RuntimeParamName": get_args(RuntimeParamName),
        "host_tools.fuzz.PARAM_TEMPLATE": tuple(PARAM_TEMPLATE),
    }
    differ = {name: names for name, names in lists.items() if names != WIRE_NAMES}
    assert differ == {}, f"run-time parameter lists that disagree with {WIRE_NAMES}: {differ}"
    assert [int(m) for m in wire.ParamMask] == [1 << k for k in range(len(WIRE_NAMES))]
    assert set(admission.PARAM_LIMITS) == {p.name for p in RUNTIME_PARAM_WORDS if p.lo is not None}
    assert set(REF_ROWS) <= set(WIRE_NAMES)  # the compiled engine's reference rows are run-time words


KNOWN_COPIES = {"plant/emt/service_loop.py": "a REQUEST's blank words, written out (2026-12-06, the EMT work): "
                                             "to become sdvisc.vocabulary.BLANK_REQUEST_PARAMS"}
"""Modules still holding a copy of the list, each with what it is and what it is to become: a copy
there must agree with the wire's words; a copy anywhere else fails."""


def _literal_copies() -> dict[str, list[tuple[int, set[str]]]]:
    copies: dict[str, list[tuple[int, set[str]]]] = {}
    for package in ("sdvisc", "sdc_unit", "sdn_app", "owfcc", "host_tools", "plant", "scenarios", "benchmarks"):
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.name in ("wire_layouts.py", "law_kernels.py"):
                continue
            for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
                items = node.elts if isinstance(node, (ast.Tuple, ast.List, ast.Set)) else (
                    node.keys if isinstance(node, ast.Dict) else [])
                names = {i.value for i in items if isinstance(i, ast.Constant) and isinstance(i.value, str)}
                if len(names & set(WIRE_NAMES)) >= 5:
                    copies.setdefault(str(path.relative_to(ROOT)), []).append((node.lineno, names & set(WIRE_NAMES)))
    return copies


def test_no_module_spells_the_runtime_parameter_list_out():
    """The list (h, d, m_q, v_ref, q_ref, supp) is written once, in sdvisc/wire_layouts.py: a literal
    holding five or more of its names elsewhere is a second copy that can fall out of step (the
    compiled engine's four reference rows, tustin_jit.REF_ROWS, are its own layout: checked above to
    be run-time words; law_kernels.PARAM_ROWS is the row layout of every ViSC parameter, 29 names).
    The copies of KNOWN_COPIES must at least agree with the wire (every word, no other)."""
    copies = _literal_copies()
    assert sorted(set(copies) - set(KNOWN_COPIES)) == []
    disagree = [(path, line) for path, found in copies.items() for line, names in found if names != set(WIRE_NAMES)]
    assert disagree == []


@pytest.mark.parametrize("name", list(LAWS))
def test_every_law_declares_its_parameters_and_its_runtime_ones_are_wire_words(name):
    law = get_law(name)
    for decl in law.declarations():
        if decl.runtime:
            assert decl.name in vocabulary.PARAM_UNITS, f"{name}.{decl.name}: run-time but no REQUEST word"
            assert decl.unit == vocabulary.PARAM_UNITS[decl.name], f"{name}.{decl.name}: unit differs from the wire's"
            lo, hi = vocabulary.PARAM_LIMITS.get(decl.name, (-np.inf, np.inf))
            assert lo <= float(decl.default) <= hi, f"{name}.{decl.name}: default outside the admitted range"
    if law.rhs is not None:  # every parameter with its source (or the reason for its value)
        assert all(d.source for d in law.declarations()), [d.name for d in law.declarations() if not d.source]
        assert law.out_rows[:7] == ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q", "omega", "e_mag", "limited")


def test_an_unknown_law_is_named_with_the_known_ones():
    with pytest.raises(ValueError, match="unknown SDC law 'vsm2'; known: visc, hold, droop"):
        ControllerBank(4, 0.67e-3, law="vsm2")


def _visc_both_ways(ts: float, seconds: float = 0.5) -> tuple[float, float]:
    """(largest gap, largest move) of v_ref_d, v_ref_q, delta, omega between the hand-derived Tustin
    and the generic trapezoid of the ViSC law, held measurements with a 0.05 p.u. power step at 67 ms."""
    hand = DiscreteVisc(1, ViscParams(), ts=ts, method="tustin")
    generic = TrapezoidControllers(LAWS["visc"], 1, ts)
    start = SimpleNamespace(**{k: np.array([v]) for k, v in OP.items()})
    hand.initialise([0], start)
    generic.initialise([0], start)
    gap = moved = 0.0
    first = None
    for k in range(round(seconds / ts)):
        m = dict(OP, p=OP["p"] + (0.05 if k * ts > 0.067 else 0.0))
        rows = np.array([[m[f]] for f in vocabulary.MEAS_FIELDS])
        a = hand.step(rows)
        _, out, _ = generic.advance_slots(np.array([0]), rows)
        got = np.array([a.v_ref_d[0], a.v_ref_q[0], a.delta[0], a.omega[0]])
        first = got if first is None else first
        gap = max(gap, float(np.max(np.abs(got - out[[0, 1, 4, 5], 0]))))
        moved = max(moved, float(np.max(np.abs(got - first))))
    return gap, moved


def test_generic_trapezoid_of_the_visc_law_follows_the_hand_derived_tustin():
    """The same law, two discretisations of the trapezoidal rule: the hand-derived block-by-block
    Tustin (DiscreteVisc, which keeps its engine) and the generic one of the law's rhs. They differ in
    how the limiter and the swing's speed are sampled (a backward difference, docs/sdc.md), so not
    bit for bit: at Ts = 0.67 ms the gap is below 0.5 % of how far the step moves the outputs, and it
    shrinks with Ts (both converge to the continuous law)."""
    gap, moved = _visc_both_ways(0.67e-3)
    fine_gap, _ = _visc_both_ways(0.067e-3)
    assert moved > 0.1
    assert gap < 5e-3 * moved
    assert fine_gap < gap / 5


def test_the_visc_bank_is_the_hand_derived_engine():
    """law="visc" (the default) builds the very DiscreteVisc of before: same engine, same bytes."""
    bank = ControllerBank(3, 0.67e-3)
    assert isinstance(bank.visc, DiscreteVisc) and bank.compiled_answers
    assert ControllerBank(3, 0.67e-3, method="hold").law.name == "hold"  # the former spelling


def test_the_hold_law_holds_the_first_operating_points_converter_voltage():
    """hold, through the bank as any law: the answer is v + (r_f + j x_f) i of the first sample,
    whatever comes after; speed 1, no limiter."""
    bank = ControllerBank(3, 0.67e-3, law="hold")
    bank.start(2, {"mask": 0})
    first = np.array([[OP[f]] for f in vocabulary.MEAS_FIELDS])
    later = np.array([[OP[f] * 0.5] for f in vocabulary.MEAS_FIELDS])
    v, i = OP["v_d"] + 1j * OP["v_q"], OP["i_d"] + 1j * OP["i_q"]
    held = v + complex(vocabulary.FILTER_R_F_PU, vocabulary.FILTER_X_F_PU) * i
    for rows in (first, later):
        out, valid = bank.step(np.array([2]), rows)
        assert valid.all() and out["v_ref_d"][0] == held.real and out["v_ref_q"][0] == held.imag
        assert out["e_mag"][0] == abs(held) and out["omega"][0] == 1.0 and not out["limited"][0]
    assert bank.runtime_params(2) == {}


@pytest.mark.parametrize("name", [n for n, law in LAWS.items() if law.rhs is not None])
def test_the_compiled_trapezoid_is_the_numpy_one(name):
    """The generic trapezoid's two engines on every law with a rhs, through a power step and a
    voltage dip: the same trajectory to 1e-9 (each column's iteration stops at its own convergence
    in the compiled engine, at all columns' in numpy's)."""
    ts = 0.67e-3
    runs = {e: TrapezoidControllers(LAWS[name], 2, ts, engine=e) for e in ("compiled", "numpy")}
    start = SimpleNamespace(**{k: np.array([v, v]) for k, v in OP.items()})
    gap = 0.0
    for ctrl in runs.values():
        ctrl.initialise([0, 1], start)
    for k in range(600):
        m = dict(OP, p=OP["p"] + (0.05 if k > 100 else 0.0), v_d=OP["v_d"] * (0.7 if 300 < k < 400 else 1.0))
        rows = np.array([[m[f], m[f]] for f in vocabulary.MEAS_FIELDS])
        (_, a, _), (_, b, _) = (c.advance_slots(np.array([0, 1]), rows) for c in runs.values())
        gap = max(gap, float(np.max(np.abs(a - b))))
    assert gap < 1e-9


def _fixed_source_rhs(x, m, c, dx, out):
    """A made-up law for the test: a voltage source at nominal frequency, E = v_ref behind l_v."""
    i_d = (c[0] * np.sin(x[0]) - m[1]) / c[1]  # i = (E e^{jδ} − v)/(j l_v), with m[0], m[1] = v_d, v_q
    i_q = -(c[0] * np.cos(x[0]) - m[0]) / c[1]
    out[0] = c[0] * np.cos(x[0])
    out[1] = c[0] * np.sin(x[0])
    out[2] = i_d
    out[3] = i_q
    out[4] = 1.0 + 0.0 * x[0]
    out[5] = c[0] + 0.0 * x[0]
    out[6] = 0.0 * x[0]
    dx[0] = 0.0 * x[0]


def test_a_new_law_is_its_module_and_a_registry_line(monkeypatch):
    """A law defined here and registered with one line (LAWS["fixed"] = ...) runs in the SDC's bank,
    takes a REQUEST's v_ref and is accepted by the scenario schema: nothing else to touch."""
    from dataclasses import dataclass

    from scenarios.schema import SdcSpec
    from sdc_unit.law_spec import Law, param

    @dataclass(frozen=True)
    class FixedParams:
        v_ref: float = param(1.0, "p.u.", "nominal voltage", runtime=True)
        l_v: float = param(0.2, "p.u.", "the ViSC's virtual inductance [D'Arco 2015]")

    def initial(m, p):
        return np.arctan2(m[1] + p.l_v * m[2], m[0] - p.l_v * m[3])[None, :]  # angle of v + j l_v i

    def bank(n, step_s, method, dtype):
        return TrapezoidControllers(LAWS["fixed"], n, step_s, engine="numpy")

    monkeypatch.setitem(LAWS, "fixed", Law("fixed", FixedParams, ("delta",), rhs=_fixed_source_rhs,
                                            param_row_names=("v_ref", "l_v"), initial_state=initial, bank=bank,
                                            methods=("tustin",)))
    assert SdcSpec(law="fixed").law == "fixed"
    test_every_law_declares_its_parameters_and_its_runtime_ones_are_wire_words("fixed")
    bank_ = ControllerBank(2, 0.67e-3, law="fixed")
    bank_.start(0, {"mask": 0})
    rows = np.array([[OP[f]] for f in vocabulary.MEAS_FIELDS])
    out, valid = bank_.step(np.array([0]), rows)
    assert valid.all() and out["omega"][0] == 1.0 and abs(out["e_mag"][0] - 1.0) < 1e-12
    bank_.set_params(0, {**vocabulary.BLANK_REQUEST_PARAMS, "mask": int(wire.ParamMask.V_REF), "v_ref": 1.05})
    out, _ = bank_.step(np.array([0]), rows)
    assert abs(out["e_mag"][0] - 1.05) < 1e-12 and bank_.runtime_params(0) == {"v_ref": 1.05}
