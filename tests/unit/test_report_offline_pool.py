"""The report's offline experiments on two cores (report/offline_pool.py): every experiment runs
once, the one that keeps results for a later experiment runs in the report's process, the page
lists them in the registry's order whatever order they finished in, and a worker that dies costs
only the experiment it had (no simulation: the experiments sleep and say where they ran)."""

from __future__ import annotations

import os
import time

import pytest

from report import offline_pool
from report.registry import Context, Experiment, Finding, PaperClaim
from report.run import run_report

MAIN_PID = os.getpid()


def _where(id_: str, sleep_s: float = 0.3, *, keeps_for: str = "", die_in_worker: bool = False) -> Experiment:
    def run(ctx: Context):  # a closure: pickle could not carry it to a worker
        if die_in_worker and os.getpid() != MAIN_PID:
            os._exit(3)
        time.sleep(sleep_s)
        return {f"{id_}.a": Finding(str(os.getpid()), "yes", measured={"pid": os.getpid()})}
    return Experiment(id_, f"title {id_}", "Fig. x", "offline", (PaperClaim(f"{id_}.a", "claim", "1"),), run, "",
                      keeps_for=keeps_for)


@pytest.fixture
def two_cores(monkeypatch):
    monkeypatch.setattr(offline_pool.os, "cpu_count", lambda: 2)


def _pids(data: dict) -> dict[str, int]:
    return {r["experiment"]: r["measured"]["pid"] for r in data["claims"] if r["verdict"] == "yes"}


def test_offline_experiments_share_two_processes_and_the_page_keeps_the_registry_order(tmp_path, two_cores):
    exps = [_where("A"), _where("K", keeps_for="Knet"), _where("B"), _where("C"), _where("D")]
    lines = []
    data = run_report(exps, tmp_path, quick=False, argv=[], progress=lines.append, offline_on_two_cores=True)
    pids = _pids(data)
    assert data["complete"] and [e["id"] for e in data["experiments"]] == ["A", "K", "B", "C", "D"]
    assert [r["id"] for r in data["claims"]] == ["A.a", "K.a", "B.a", "C.a", "D.a"]
    assert pids["K"] == MAIN_PID  # what a later experiment reuses stays in this process
    assert len(set(pids.values())) == 2 and set(pids.values()) - {MAIN_PID}  # the others were shared
    assert data["offline_phase"]["experiments"] == 5  # the page says their wall times overlap
    assert "ran side by side on two cores" in (tmp_path / "index.html").read_text()
    finished = [line for line in lines if " ok in " in line]
    assert len(finished) == 5 and all(line.startswith("report: [") for line in finished)


def test_a_dead_worker_fails_only_its_experiment_and_the_rest_run_here(tmp_path, two_cores):
    # the worker takes the shared ones from the registry's last: A is its first
    exps = [_where("B"), _where("K", 0.5, keeps_for="Knet"), _where("C"), _where("A", die_in_worker=True)]
    data = run_report(exps, tmp_path, quick=False, argv=[], progress=lambda line: None, offline_on_two_cores=True)
    status = {e["id"]: e["status"] for e in data["experiments"]}
    assert status == {"B": "ok", "K": "ok", "C": "ok", "A": "failed"}
    error = next(e["error"] for e in data["experiments"] if e["id"] == "A")
    assert "worker process died (exit code 3)" in error
    assert set(_pids(data).values()) == {MAIN_PID}
    assert data["complete"] and not data["pending"]


def test_one_core_or_nothing_to_share_runs_everything_here(tmp_path, monkeypatch):
    monkeypatch.setattr(offline_pool.os, "cpu_count", lambda: 1)
    exps = [_where("A", 0.0), _where("B", 0.0)]
    data = run_report(exps, tmp_path, quick=False, argv=[], progress=lambda line: None, offline_on_two_cores=True)
    assert set(_pids(data).values()) == {MAIN_PID}
    assert not offline_pool.worth_it([_where("K", keeps_for="Knet"), _where("L", keeps_for="Lnet")], [0, 1])
