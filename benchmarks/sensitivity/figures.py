"""The study's figures: a tornado per claim (open choices marked *) and F9's V traces."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from benchmarks.sensitivity.common import OPEN, RANGE  # noqa: E402


def figure(summary: dict, path: Path) -> None:
    """A tornado: per row the claim's number at each tried value (range ends: blue low, red high;
    alternatives: green), the default as a vertical line, the paper's value and its ±10 % shaded;
    values for which the number does not exist (n/a) are named under the row, not plotted."""
    rows = summary["parameters"] + ([{"parameter": "best corner (all range ends towards the paper)", "kind": RANGE,
                                      "values": {"corner": summary["best_corner"]["value"]}}]
                                    if "best_corner" in summary else [])
    paper, default = summary["paper"], summary["default"]
    finite = [v for r in rows for v in r["values"].values() if v is not None] + [paper] + (
        [default] if default is not None else [])
    lo, hi = min(finite), max(finite)
    pad = 0.08 * (hi - lo or 1.0)
    fig, ax = plt.subplots(figsize=(9.0, 1.4 + 0.5 * len(rows)))
    if summary.get("band", True):
        ax.axvspan(0.9 * paper, 1.1 * paper, color="0.9", zorder=0, label="paper ±10 %")
        ax.axvline(paper, color="k", lw=1.2, label=f"paper {paper:g} {summary['unit']}")
    else:
        ax.axvline(paper, color="k", lw=1.2, ls=":", label=f"paper: below the SC's ({paper:g})")
    if default is not None:
        ax.axvline(default, color="C2", ls="--", lw=1.0, label=f"testbed default {default:.3g}")
    else:
        ax.plot([], [], " ", label="testbed default: n/a")
    for y, r in enumerate(reversed(rows)):
        items = list(r["values"].items())
        xs = [v for _, v in items if v is not None] + ([default] if default is not None else [])
        if xs:
            ax.plot([min(xs), max(xs)], [y, y], color="0.6", lw=4, alpha=0.5, solid_capstyle="butt")
        missing = []
        for j, (label, v) in enumerate(items):
            color = "C2" if r["kind"] == OPEN else ("C0" if j == 0 and len(items) > 1 else "C3")
            if v is None:
                missing.append(label)
                continue
            ax.plot([v], [y], "o", color=color, ms=6)
            below = j % 2 == 0 if len(items) > 2 else j == 0 and len(items) > 1  # many values: alternate
            ax.annotate(label, (v, y), textcoords="offset points", xytext=(0, -11 if below else 5),
                        ha="center", fontsize=6.5 if len(items) <= 2 else 5.5, color=color)
        if missing:
            ax.annotate("n/a: " + "; ".join(missing), (lo - pad, y), textcoords="offset points", xytext=(2, -12),
                        ha="left", fontsize=6.5, color="0.35", style="italic")
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([("* " if r["kind"] == OPEN else "") + r["parameter"] for r in reversed(rows)], fontsize=7)
    ax.set_xlim(lo - pad, hi + pad)
    ax.set_ylim(-0.8, len(rows) - 0.4)
    ax.set_xlabel(f"{summary['id']} [{summary['unit']}]")
    ax.set_title(f"{summary['id']}: {summary['claim']}", fontsize=8, loc="left", wrap=True)
    ax.grid(alpha=0.3, axis="x")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.text(0.01, 0.005, "blue: low end, red: high end of a source range; green, *: an open choice (structure, bus, "
             "reading, fault type/resistance: not a range, never in the corner; reaching the paper only through it = "
             "'consistent'); n/a: the number does not exist there. benchmarks/claim_sensitivity.py", fontsize=6.5,
             style="italic")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def figure_f9_traces(raw: dict, path: Path) -> list[str]:
    """WT1_CS1's terminal voltage (F9.d's reading) with 3 SDViSCs at SCR 1.51 for the default (its PCC
    dashed) and every variation that changes the 3-SDViSC state; the paper's 3 s and the band marked."""
    fig, ax = plt.subplots(figsize=(9.0, 4.2))
    shown = []
    base = raw["default"]["state_3"]
    variants = [("default", raw["default"])] + [(f"{prm} {label}", r) for prm, runs in raw.items() if prm != "default"
                                                 for label, r in runs.items() if r["state_3"] != base]
    for k, (label, r) in enumerate(variants):
        tr = r["trace_3"]
        ax.plot(tr["t"], tr["v_wt1"], lw=1.6 if k == 0 else 0.8, color="k" if k == 0 else f"C{k % 10}",
                label=f"{label}: {r['state_3']}; WT1_CS1 away from "
                + ("—" if r["t_away_wt1_3"] is None else f"{r['t_away_wt1_3']:.2f} s"))
        if k == 0:
            ax.plot(tr["t"], tr["v_pcc"], lw=0.8, color="k", ls="--", label="default, PCC")
        shown.append(label)
    for v in (0.9, 1.1):
        ax.axhline(v, color="0.5", ls=":", lw=0.8)
    ax.axvline(3.0, color="C3", ls="--", lw=0.9, label="paper: 3 SDViSCs stable until ~3 s")
    ax.set_xlabel("t [s] (SCR 7.14 -> 1.51 at 1 s, 3 SDViSCs of cluster 3)")
    ax.set_ylabel("|V| WT1_CS1 terminal [p.u.]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return shown


