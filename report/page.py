"""index.html: one self-contained page (figures embedded as data URIs, no external files or
scripts): the machine and time scale, the claims table, each experiment with its figures, the
commands."""

from __future__ import annotations

import base64
from html import escape
from pathlib import Path

from report.registry import LOCK_WAIT_KEY, MEASURED, RERUN_KEY

STYLE = """
body{font-family:system-ui,sans-serif;max-width:1200px;margin:1.5em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;width:100%;font-size:0.88em;margin:0.6em 0}
th,td{border:1px solid #ccc;padding:0.3em 0.45em;vertical-align:top;text-align:left}
th{background:#f0f0f0} code,pre{background:#f6f6f6;padding:0 0.2em;font-size:0.92em}
pre{padding:0.5em;overflow-x:auto;white-space:pre-wrap}
.v-yes{background:#d9f2d9}.v-partly{background:#fff2c2}.v-no{background:#f8d4d4}.v-consistent{background:#dde8f8}
.v-failed{background:#e6c3f0}.v-not-run{background:#e4e4e4}.v-measured{background:#dde8f6}
figure{margin:1em 0}figcaption{font-size:0.85em;font-style:italic;max-width:900px}
img{max-width:100%;border:1px solid #ddd}.small{font-size:0.85em;color:#555}
"""


def _verdict_cell(verdict: str, shown: str | None = None) -> str:
    return f'<td class="v-{escape(verdict.replace(" ", "-"))}"><b>{escape(shown or verdict)}</b></td>'


def _machine(data: dict) -> str:
    b, a = data["machine"]["before"], data["machine"]["after"]
    return (f"<p>{b['cpu_count']} CPUs, kernel <code>{escape(b['kernel'])}</code>, Python {escape(b['python'])}; "
            f"load average (1, 5, 15 min) {b['load_average']} at the start, {a['load_average']} at the end; "
            f"written {escape(a['written'])}; the whole report took {data['wall_s']} s"
            f"{_lock_text(data.get('lock_wait_s'))}"
            f"{' (--quick: coarser searches, shorter windows)' if data['quick'] else ''}."
            f"{_switch_ports_text(data)}</p>")


def _switch_ports_text(data: dict) -> str:
    """Which switch ports the network runs had (scenarios/switch_ports.py): it sets their hop cost."""
    used = sorted({kind for e in data["experiments"] for kind in (e.get("numbers", {}).get("switch_ports") or {}).values()})
    if not used:
        return ""
    return (f" Switch ports of the network runs: {escape(', '.join(used))} (system: polled by ovs-vswitchd's main "
            "thread; afxdp: a PMD thread spinning one core).")


def _claims(rows: list[dict]) -> str:
    head = ("<tr><th>claim</th><th>kind</th><th>the paper says</th><th>paper's value</th><th>this testbed</th>"
            "<th>reproduced</th><th>reason / evidence</th><th>command</th></tr>")
    return KINDS_TEXT + f"<table>{head}{_rows(rows)}</table>"


def _beyond(rows: list[dict]) -> str:
    """Questions the paper does not ask (issue 9), offline sweeps: the paper's qualitative statements
    they test stay in the claims table; what they measured beyond it is here."""
    if not rows:
        return ""
    intro = ("<p>Offline sweeps (one process, plant/cosim.py; no network: a delay is the CTRL held at the "
             "turbine). The paper gives no number for these: each row says what the paper states about it, "
             "if anything, and what this testbed measured (no verdict: <i>measured</i>). The paper's "
             "qualitative statements the same sweeps test are in the claims table above.</p>")
    head = ("<tr><th>item</th><th>kind</th><th>question</th><th>what the paper states</th><th>this testbed</th>"
            "<th></th><th>criteria / evidence</th><th>command</th></tr>")
    return "<h2>Beyond the paper</h2>" + intro + f"<table>{head}{_rows(rows)}</table>"


def _rows(rows: list[dict]) -> str:
    return "".join(
        f"<tr><td><a href='#{escape(r['experiment'])}'>{escape(r['id'])}</a></td><td>{escape(r['kind'])}</td>"
        f"<td>{escape(r['claim'])}</td>"
        f"<td>{escape(r['paper'])}</td><td>{escape(r['testbed'])}</td>{_verdict_cell(r['verdict'])}"
        f"<td>{escape(r['reason'])}</td><td><code>{escape(r['command'])}</code></td></tr>" for r in rows)


KINDS_TEXT = ("<p class='small'>Kind: <i>reproduction</i> = compared with a number or behaviour the paper states "
              "(only these count in the headline); <i>consistency</i> = the testbed against itself (e.g. a network "
              "run against the same case offline); <i>input</i> = a value the model is given (e.g. the 1.5 p.u. "
              "current limit).</p>")


def _printed(data: dict) -> str:
    """The paper's printed magnitudes, each once (report/printed.py), read on each model: the phasor plant and,
    where it covers the magnitude, the EMT backend (issue 40), with the headline of each."""
    entries = data.get("printed_magnitudes") or []
    if not entries:
        return ""
    head = ("<tr><th>magnitude</th><th>the paper</th><th>reading (phasor plant)</th><th>phasor plant</th>"
            "<th>verdict</th><th>alternatives</th><th>EMT backend (reading, value)</th><th>EMT verdict</th></tr>")
    body = "".join(
        f"<tr><td>{escape(e['magnitude'])} ({escape(e['claim'])})</td><td><i>{escape(e['quote'])}</i></td>"
        f"<td>{escape(e['reading'])}</td><td>{escape(str(e['value']))}</td>{_verdict_cell(e['verdict'])}"
        f"<td class='small'>{escape('; '.join(f'{k}: {v}' for k, v in e['alternatives'].items()))}</td>"
        f"{_printed_emt(e.get('emt') or {})}</tr>"
        for e in entries)
    per_model = data["headline"].get("per_model") or {}
    emt_text = f" <b>{escape(per_model['emt']['text'])}</b>." if "emt" in per_model else ""
    return (f"<p><b>Phasor plant: {escape(data['headline']['text'])}</b> ({data['headline']['evaluated']} evaluated in "
            f"this run).{emt_text} Each model counted on its own, never the better of the two; consistent = reached "
            "only through a parameter the paper does not state, inside a cited range: not counted as reproduced.</p>"
            f"<table>{head}{body}</table>")


def _printed_emt(emt: dict) -> str:
    verdict = emt.get("verdict", "not on EMT")
    if not emt.get("claim"):
        return "<td class='small'>—</td>" + _verdict_cell("not run", verdict)
    alt = "; ".join(f"{k}: {v}" for k, v in (emt.get("alternatives") or {}).items())
    text = f"{emt.get('reading', '')}: {emt.get('value', '')}" + (f" ({alt})" if alt else "")
    cls = verdict if verdict != "not on EMT" else "not run"
    return (f"<td class='small'><a href='#emt-vs-phasor'>{escape(emt['claim'])}</a> {escape(text)}</td>"
            + _verdict_cell(cls, verdict))


EMT_EXPERIMENTS = ("EMT", "EMTF8", "EMTW")  # report/exp_emt*.py: shown together in "EMT vs phasor"


def _emt_vs_phasor(data: dict, out_dir: Path) -> str:
    """The EMT backend's rows (each EMT value beside the phasor plant's, kind consistency) and the overlaid
    traces of F3, F6, F7/F9 and F8 (issue 40)."""
    exps = [e for e in data["experiments"] if e["id"] in EMT_EXPERIMENTS]
    if not exps:
        return ""
    rows = [r for r in data["claims"] if r.get("experiment") in EMT_EXPERIMENTS]
    head = ("<tr><th>claim</th><th>kind</th><th>the paper says</th><th>paper's value</th><th>phasor vs EMT</th>"
            "<th>agree</th><th>rule / evidence</th><th>command</th></tr>")
    parts = ["<h2 id='emt-vs-phasor'>EMT vs phasor</h2>",
             "<p>The paper's device-level cases again on the EMT backend (plant/emt/, DPsim 1.4.0, three-phase at "
             "Ts/13 = 51.5 µs) beside the phasor plant, started from the same load flow; the verdict here is the two "
             "models' agreement (yes within 5 %, or 0.1 SCR for a boundary). Dashed: EMT; solid: phasor. What the EMT "
             "circuit leaves out is in docs/plant.md, \"EMT backend\".</p>",
             f"<table>{head}{_rows(rows)}</table>"]
    for e in exps:
        parts.append(f"<h3>{escape(e['id'])}: {escape(e['title'])} <span class='small'>({escape(e['status'])}, "
                     f"{e['wall_s']} s)</span></h3>")
        parts += [_figure(f, out_dir) for f in e["figures"]]
    return "\n".join(parts)


def _counts(data: dict) -> str:
    """The headline (reproductions only) and what is counted apart."""
    head = ", ".join(f"{n} {v}" for v, n in data["summary"].items() if n and v != MEASURED) or "none evaluated"
    apart = data.get("summary_apart") or {}
    parts = [f"<b>reproductions of the paper: {escape(head)}</b>"]
    parts += [f"{escape(kind)} (counted apart): " + escape(", ".join(f"{n} {v}" for v, n in c.items()))
              for kind, c in apart.items()]
    if data["summary"].get(MEASURED):
        parts.append(f"beyond the paper: {data['summary'][MEASURED]} measured")
    return "; ".join(parts)


def _experiments_table(exps: list[dict]) -> str:
    head = "<tr><th>experiment</th><th>paper figure</th><th>how</th><th>status</th><th>wall time</th><th>time scale</th></tr>"
    body = "".join(
        f"<tr><td><a href='#{escape(e['id'])}'>{escape(e['id'])}</a> {escape(e['title'])}</td>"
        f"<td>{escape(e['paper_figure'])}</td><td>{escape(e['kind'])}</td>{_verdict_cell(_status_class(e['status']), e['status'])}"
        f"<td>{e['wall_s']} s{_waited(e)}</td><td>{escape(_time_scale_text(e['time_scale'], e.get('numbers', {}).get(RERUN_KEY)))}</td></tr>" for e in exps)
    return f"<table>{head}{body}</table>"


def _offline_phase_text(phase: dict | None) -> str:
    """The offline experiments' wall times overlap when they ran side by side: say so, with the phase's own."""
    if not phase:
        return ""
    return (f"<p class='small'>The {phase['experiments']} offline experiments ran side by side on two cores (this "
            f"process and one worker), each slower beside the other: their wall times overlap; the offline phase "
            f"took {phase['wall_s']} s.</p>")


def _waited(exp: dict) -> str:
    wait = sum((exp.get("numbers", {}).get(LOCK_WAIT_KEY) or {}).values())
    return f" ({wait:.0f} s of it waiting for the network lock)" if wait >= 1 else ""


def _lock_text(wait_s) -> str:
    return f", {wait_s} s of it waiting for the network lock (other work's runs)" if wait_s else ""


def _time_scale_text(time_scale, again: dict | None = None) -> str:
    """A cyber experiment's time scales ({run: k}) as "k = 16 (run)", with the calibrated k a run did
    not hold at (``again``: report.network_runs.RERUN_KEY); an offline one's text as is."""
    if isinstance(time_scale, dict):
        def one(run, k):
            if not isinstance(k, (int, float)):
                return f"{run}: {k}"
            first = (again or {}).get(run)
            did_not_hold = f"; at k = {first['time_scale']:g} it did not hold" if first else ""
            return f"k = {k:g} ({run}{did_not_hold})"
        return "; ".join(one(run, k) for run, k in time_scale.items()) or "—"
    return str(time_scale)


def _status_class(status: str) -> str:
    return {"ok": "yes"}.get(status, status)


def _figure(fig: dict, out_dir: Path) -> str:
    png = out_dir / fig["png"]
    src = "data:image/png;base64," + base64.b64encode(png.read_bytes()).decode() if png.exists() else ""
    return (f"<figure><img alt='{escape(fig['name'])}' src='{src}'><figcaption>{escape(fig['caption'])} "
            f"<span class='small'>({escape(fig['png'])}, {escape(fig['svg'])})</span></figcaption></figure>")


def _experiment(e: dict, out_dir: Path) -> str:
    parts = [f"<h3 id='{escape(e['id'])}'>{escape(e['id'])}: {escape(e['title'])} "
             f"<span class='small'>({escape(e['paper_figure'])}; {escape(e['kind'])}; {escape(e['status'])}, "
             f"{e['wall_s']} s)</span></h3>"]
    if e["scope"]:
        parts.append(f"<p>{escape(e['scope'])}</p>")
    if e["error"]:
        parts.append(f"<p><b>{escape(e['status'])}:</b></p><pre>{escape(e['error'])}</pre>")
    parts.append(f"<p class='small'>command: <code>{escape(e['command'])}</code></p>")
    parts += [f"<p class='small'>{escape(n)}</p>" for n in e["notes"]]
    if e["id"] in EMT_EXPERIMENTS:  # its figures once, in the EMT section
        parts.append("<p class='small'>figures: <a href='#emt-vs-phasor'>EMT vs phasor</a></p>")
    else:
        parts += [_figure(f, out_dir) for f in e["figures"]]
    return "\n".join(parts)


def render(data: dict, out_dir: Path) -> str:
    return "\n".join([
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        "<title>SDViSC testbed: the paper's Section IV reproduced</title>",
        f"<style>{STYLE}</style></head><body>",
        "<h1>SDViSC testbed: the paper's Section IV, claim by claim</h1>",
        (f"<p><b>Partial: still to run: {escape(', '.join(data['pending']))}</b> (the page is rewritten after "
         "each experiment).</p>" if data.get("pending") else ""),
        f"<p>Command: <code>{escape(data['command'])}</code>. Claims: {_counts(data)}. The paper's values are typed "
        "from the paper; every value in the column <i>this testbed</i> and every verdict is computed by the "
        "experiment (tolerances in report/verdicts.py: a number within 10 % of the paper's is reproduced, within "
        "35 % partly; consistent: only an unstated parameter inside a cited range reaches it).</p>",
        "<h2>The paper's printed magnitudes</h2>", _printed(data),
        "<h2>Machine and time scale</h2>", _machine(data),
        "<h2>Experiments</h2>", _experiments_table(data["experiments"]), _offline_phase_text(data.get("offline_phase")),
        "<h2>Claims</h2>", _claims([r for r in data["claims"] if not r.get("beyond")]),
        _beyond([r for r in data["claims"] if r.get("beyond")]),
        _emt_vs_phasor(data, out_dir),
        "<h2>Figures and details</h2>",
        *[_experiment(e, out_dir) for e in data["experiments"]],
        "</body></html>",
    ])
