"""Figures: matplotlib (Agg), each saved as PNG and SVG with the paper's claim as its caption."""

from __future__ import annotations

import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from report.registry import Context, Figure  # noqa: E402

FAULT_SHADE = {"color": "0.88", "zorder": 0}


def new(rows: int, cols: int = 1, height_per_row: float = 2.1, width: float = 8.0, sharex: bool = True):
    """A figure with ``rows`` × ``cols`` axes (always a 2-D array of axes)."""
    fig, axes = plt.subplots(rows, cols, figsize=(width, 0.9 + height_per_row * rows), sharex=sharex, squeeze=False)
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    return fig, axes


def save(ctx: Context, fig, name: str, caption: str, prefix: str = "Paper: ", top: float = 1.0) -> Figure:
    """Write ``name``.png and ``name``.svg into the output directory, the caption under the axes
    (``prefix``: what the caption is, by default the paper's claim; ``top`` < 1 leaves room above the
    axes, e.g. for a figure legend)."""
    fig.text(0.01, 0.005, "\n".join(textwrap.wrap(prefix + caption, 120)), fontsize=7.5, va="bottom", ha="left",
             style="italic")
    fig.tight_layout(rect=(0, 0.06, 1, top))
    png, svg = ctx.out_dir / f"{name}.png", ctx.out_dir / f"{name}.svg"
    fig.savefig(png, dpi=100)
    fig.savefig(svg)
    plt.close(fig)
    figure = Figure(name, caption, png, svg)
    ctx.figures.append(figure)
    return figure
