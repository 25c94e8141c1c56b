"""What an experiment is: the paper's claims it checks (typed from the paper, the only hand-typed
side of the report), how it runs (offline or cyber-in-the-loop) and what it found."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

VERDICTS = ("yes", "partly", "consistent", "no")  # what a computed finding can say ("consistent": report/verdicts.py)
LOCK_WAIT_KEY = "network_lock_wait_s"  # Context.numbers: per network run, wall seconds waiting for the lock
RERUN_KEY = "run_again"  # Context.numbers: the calibrated runs that did not hold and ran again at twice their k
MEASURED = "measured"  # a question the paper does not ask (``PaperClaim.beyond``): a value, no verdict
NOT_EVALUATED = ("failed", "not run")  # what the report says when no finding exists
# What a claim's finding is compared against (issue 28, item 9): only reproductions count in the headline.
REPRODUCTION = "reproduction"  # against a number or behaviour the paper states
CONSISTENCY = "consistency"  # the testbed against itself (e.g. a network run against the same case offline)
INPUT = "input"  # a value that is an input of the model (e.g. the 1.5 p.u. current limit the law is given)
CLAIM_KINDS = (REPRODUCTION, CONSISTENCY, INPUT)


@dataclass(frozen=True)
class PaperClaim:
    """One claim of the paper's Section IV, as the paper states it."""

    id: str  # e.g. "F6.b"
    text: str  # the claim in words
    paper: str  # the paper's value, as printed
    beyond: bool = False  # a question beyond the paper (issue 9): ``paper`` says what the paper states
    # about it ("not stated" if nothing), its finding is MEASURED, the page shows it in its own section
    kind: str = ""  # one of CLAIM_KINDS, what the finding is compared against; if not given: REPRODUCTION
    # for a claim of the paper, CONSISTENCY beyond it (no value of the paper's: only the testbed's own)

    def __post_init__(self) -> None:
        if not self.kind:
            object.__setattr__(self, "kind", CONSISTENCY if self.beyond else REPRODUCTION)
        if self.kind not in CLAIM_KINDS:
            raise ValueError(f"claim {self.id}: kind {self.kind!r} is not one of {CLAIM_KINDS}")
        if self.beyond and self.kind == REPRODUCTION:
            raise ValueError(f"claim {self.id} is beyond the paper: there is nothing of the paper's to reproduce")


@dataclass
class Finding:
    """What an experiment measured for one claim; ``verdict`` is computed, never typed."""

    testbed: str  # this testbed's value, formatted from ``measured``
    verdict: str  # one of VERDICTS, or MEASURED for a claim beyond the paper
    reason: str = ""  # why not (with the evidence) where the verdict is not "yes"; may explain a "yes"
    measured: dict = field(default_factory=dict)  # the raw numbers behind ``testbed``

    def __post_init__(self) -> None:
        if self.verdict not in (*VERDICTS, MEASURED):
            raise ValueError(f"verdict {self.verdict!r} is not one of {VERDICTS} (or {MEASURED!r})")
        if self.verdict not in ("yes", MEASURED) and not self.reason.strip():
            raise ValueError(f"a '{self.verdict}' verdict needs its reason (with the evidence): {self.testbed}")


@dataclass
class Figure:
    name: str  # file stem in the output directory
    caption: str  # the paper's claim the figure shows
    png: Path
    svg: Path


@dataclass
class Context:
    """What an experiment gets: the options and a place for its figures and notes."""

    out_dir: Path
    quick: bool = False
    figures: list[Figure] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    numbers: dict = field(default_factory=dict)  # extra measured values for claims.json


@dataclass(frozen=True)
class Experiment:
    id: str  # "F1" ... "F9", "C1" ... "C3"
    title: str
    paper_figure: str  # which of the paper's figures it redraws
    kind: str  # "offline" (one process, no network) or "cyber" (scenario through the network)
    claims: tuple[PaperClaim, ...]
    run: Callable[[Context], dict[str, Finding]]
    command: str  # how to run it alone
    scope: str = ""  # what it runs and what it cannot (e.g. "offline only: <reason>")
    keeps_for: str = ""  # a later experiment that reuses what this one keeps in the report's process
    # (e.g. F7's boundary search, for F7net): it runs in that process, not in the offline worker

    def __post_init__(self) -> None:
        if self.kind not in ("offline", "cyber"):
            raise ValueError(f"experiment kind {self.kind!r}")
        for claim in self.claims:
            if not claim.id.startswith(self.id + "."):
                raise ValueError(f"claim {claim.id} does not belong to experiment {self.id}")


def relabelled(experiments: Iterable[Experiment], kinds: dict[str, str]) -> tuple[Experiment, ...]:
    """The experiments with the claims named in ``kinds`` (claim id → one of CLAIM_KINDS) given that
    kind; an id no experiment has is an error. For claims declared in modules whose owners are busy
    elsewhere: the kind belongs in the declaration when that module is next edited."""
    experiments = tuple(experiments)
    unknown = set(kinds) - {c.id for e in experiments for c in e.claims}
    if unknown:
        raise ValueError(f"no such claim(s) to relabel: {', '.join(sorted(unknown))}")
    return tuple(replace(e, claims=tuple(replace(c, kind=kinds[c.id]) if c.id in kinds else c for c in e.claims))
                 for e in experiments)


def select(experiments: Iterable[Experiment], only: str | None) -> list[Experiment]:
    """The experiments named in ``only`` ("F4,C2", case-insensitive), in registry order; all if None.
    An unknown name is an error naming the known ones."""
    experiments = list(experiments)
    if not only:
        return experiments
    wanted = [w.strip().upper() for w in only.split(",") if w.strip()]
    known = {e.id.upper(): e for e in experiments}
    unknown = [w for w in wanted if w not in known]
    if unknown:
        raise ValueError(f"unknown experiment(s) {', '.join(unknown)}; known: {', '.join(known)}")
    return [e for e in experiments if e.id.upper() in wanted]


class NotRun(Exception):
    """Raised by an experiment that cannot run here (e.g. a cyber experiment without root); the
    report shows it as "not run" with this reason, the others still run."""
