"""SDC unit throughput: how many ViSC instances one SDC process can serve at Ts = 0.67 ms.

Prints ONE JSON object to stdout::

    .venv/bin/python benchmarks/sdc_throughput.py            # ~40 s
    .venv/bin/python benchmarks/sdc_throughput.py --quick    # ~10 s
    .venv/bin/python benchmarks/sdc_throughput.py --rt-priority   # SCHED_FIFO as the service (root)

Two measurements, both on this machine, both of what ``sdc_unit.service`` does per sample round:

* offline (``steps_per_s``): back-to-back ``ControllerBank.step`` on N slots with realistic
  measurements (N turbines at different operating points with a small ripple), and the same plus
  the service's wire work: the N MEAS datagrams decoded and checked together
  (``sdvisc.wire_batch.decode_batch``), then the service's own round code (``sdc_unit.round``: one
  vectorised bank step, the N CTRL replies packed together).
* real time (``max_instances_realtime``): a paced loop, one period per Ts; each period decodes N
  pre-encoded MEAS packets, takes one bank step and encodes N CTRL packets. Sample k is released at
  t0 + k Ts (a plant does not wait) and is late if its round finishes after t0 + (k + 1) Ts; a late
  round delays the next one (queueing, as in the service). N holds real time if fewer than 1 % of
  the rounds are late. The largest such N in 1..64 is found by bisection (assumes monotonicity;
  every probe is reported). ``n_offline_bound`` is the N at which the median round cost (a straight line
  fitted to the offline rounds) reaches Ts: an upper bound with zero slack, not a real-time result. Sockets are not included (the loopback/netns cost is measured by the
  testbed's own delay statistics), so this is an upper bound for the service.

The machine may be shared: the load average before and after is recorded with the result.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sdc_unit.bank import ControllerBank  # noqa: E402
from sdc_unit.round import pack_ctrl, step_round  # noqa: E402
from sdvisc import wire  # noqa: E402
from sdvisc.vocabulary import MEAS_FIELDS  # noqa: E402
from sdvisc.wire_batch import decode_batch  # noqa: E402

TS = 0.67e-3
LATE_LIMIT = 0.01
N_SAMPLES = 64  # distinct pre-encoded measurement samples per turbine (cycled)


# --------------------------------------------------------------------------- workload
def realistic_measurements(n: int, n_samples: int = N_SAMPLES, seed: int = 0) -> list[dict[str, np.ndarray]]:
    """``n_samples`` measurement sets for ``n`` turbines: each at its own operating point
    (P 0.2..0.9 p.u., Q -0.2..0.2 p.u., |v| 0.98..1.03, angle up to 0.15 rad) with a 50 Hz-free
    ripple of 0.2 % on v and 1 % on i, so the controllers do real work every sample."""
    rng = np.random.default_rng(seed)
    p0 = rng.uniform(0.2, 0.9, n)
    q0 = rng.uniform(-0.2, 0.2, n)
    vm = rng.uniform(0.98, 1.03, n)
    ang = rng.uniform(0.0, 0.15, n)
    out = []
    for k in range(n_samples):
        ph = 2 * math.pi * k / n_samples
        v = vm * (1 + 0.002 * np.sin(ph + ang * 10)) * np.exp(1j * ang)
        s = (p0 + 1j * q0) * (1 + 0.01 * np.cos(ph))
        i = np.conj(s / v)
        s = v * np.conj(i)
        out.append({
            "v_d": v.real, "v_q": v.imag, "i_d": i.real, "i_q": i.imag, "p": s.real, "q": s.imag,
            "v_dc": np.ones(n), "omega_meas": 1.0 + 1e-4 * np.sin(ph) * np.ones(n),
        })
    return out


def encoded_meas(n: int, samples: list[dict[str, np.ndarray]], header: bool = True) -> list[list[bytes]]:
    """The MEAS datagrams of every sample, per turbine, as the plant would send them."""
    packets = []
    for k, m in enumerate(samples):
        row = []
        for j in range(n):
            values = {"wt": wire.turbine_id(j // 10 + 1, j % 10 + 1), "seq": k, "t_sim": k * TS,
                      **{key: float(m[key][j]) for key in MEAS_FIELDS}}
            row.append(wire.encode(wire.MsgType.MEAS, values, header=wire.Header(k, 0, 0) if header else None))
        packets.append(row)
    return packets


def make_bank(n: int, method: str = "tustin", dtype: str = "float64") -> tuple[ControllerBank, np.ndarray]:
    """A bank sized as the service sizes it (one spare slot for warm-up), N slots started."""
    bank = ControllerBank(capacity=n + 1, step_s=TS, method=method, dtype=dtype)
    bank.warm_up()
    slots = np.arange(n)
    for s in slots:
        bank.start(int(s), {"mask": 0})
    return bank, slots


class ServiceRound:
    """One sample round of ``sdc_unit.service`` without the socket: decode N MEAS, then the service's own
    round (``sdc_unit.round``: step the bank, pack N CTRL)."""

    def __init__(self, n: int, method: str = "tustin", dtype: str = "float64", header: bool = True):
        self.n = n
        self.header = header
        self.bank, self.slots = make_bank(n, method, dtype)
        self.samples = realistic_measurements(n)
        self.packets = encoded_meas(n, self.samples, header)
        self.stats = wire.DecodeStats()
        self.ctrl_seq = 0
        self.seq_zero = np.zeros(n, dtype=np.int64)
        self.k = 0
        self.bank.step(self.slots, self.samples[0])  # initialise every slot (bumpless start)

    def bank_only(self) -> None:
        self.bank.step(self.slots, self.samples[self.k % N_SAMPLES])
        self.k += 1

    def full(self) -> int:
        """Returns the number of CTRL bytes produced (keeps the work observable)."""
        rec, _ = decode_batch(self.packets[self.k % N_SAMPLES], wire.MsgType.MEAS, header=self.header, stats=self.stats)
        _, ctrl = step_round(self.bank, self.slots, rec)
        self.ctrl_seq += 1
        seqs = self.seq_zero[:len(ctrl["wt"])] + self.ctrl_seq  # the service numbers per turbine
        nbytes = sum(len(b) for b in pack_ctrl(ctrl, seqs, time.time() if self.header else None))
        self.k += 1
        return nbytes


# --------------------------------------------------------------------------- measurements
def offline(n: int, seconds: float, method: str = "tustin", dtype: str = "float64", blocks: int = 10) -> dict:
    """Back-to-back steps, bank only and bank + wire (the service round), ``seconds`` each, in
    ``blocks`` interleaved blocks; per-step times are the median over the blocks (robust to other
    load on a shared machine), the spread is reported as the min..max of the block means."""
    r = ServiceRound(n, method, dtype)
    fns = {"bank": r.bank_only, "bank_wire": r.full}
    for fn in fns.values():
        for _ in range(20):
            fn()
    per = {name: [] for name in fns}
    steps = 0
    for _ in range(blocks):
        for name, fn in fns.items():
            count, t0 = 0, time.perf_counter()
            while True:
                for _ in range(5):
                    fn()
                count += 5
                el = time.perf_counter() - t0
                if el >= seconds / blocks:
                    break
            per[name].append(el / count)
            steps += count
    tb, tw = float(np.median(per["bank"])), float(np.median(per["bank_wire"]))
    return {
        "steps_per_s": round(1.0 / tb, 1),
        "steps_per_s_with_wire": round(1.0 / tw, 1),
        "us_per_step": round(tb * 1e6, 1),
        "us_per_step_with_wire": round(tw * 1e6, 1),
        "us_per_step_range": [round(min(per["bank"]) * 1e6, 1), round(max(per["bank"]) * 1e6, 1)],
        "us_per_step_with_wire_range": [round(min(per["bank_wire"]) * 1e6, 1), round(max(per["bank_wire"]) * 1e6, 1)],
        "wire_us_per_instance": round((tw - tb) / n * 1e6, 2),
        "instance_steps_per_s_with_wire": round(n / tw, 1),
        "steps": steps,
    }


def _wait_until(t: float) -> None:
    rem = t - time.perf_counter()
    if rem > 3e-4:
        time.sleep(rem - 2.5e-4)
    while time.perf_counter() < t:
        pass


def realtime(n: int, seconds: float, ts: float = TS, method: str = "tustin", dtype: str = "float64") -> dict:
    """Paced loop for ``seconds``: fraction of rounds finishing after their deadline (see module doc)."""
    r = ServiceRound(n, method, dtype)
    for _ in range(50):
        r.full()
    k_total = max(1, int(round(seconds / ts)))
    busy = np.empty(k_total)
    late = 0
    worst_lag = 0.0
    t0 = time.perf_counter() + 2e-3
    for k in range(k_total):
        release = t0 + k * ts
        _wait_until(release)
        start = time.perf_counter()
        r.full()
        end = time.perf_counter()
        busy[k] = end - start
        lag = end - (release + ts)
        if lag > 0:
            late += 1
            worst_lag = max(worst_lag, lag)
    return {
        "n": n,
        "rounds": k_total,
        "late": late,
        "late_fraction": round(late / k_total, 5),
        "holds": late / k_total < LATE_LIMIT,
        "overrun_fraction": round(float(np.mean(busy > ts)), 5),
        "round_us_p50": round(float(np.percentile(busy, 50)) * 1e6, 1),
        "round_us_p99": round(float(np.percentile(busy, 99)) * 1e6, 1),
        "round_us_max": round(float(busy.max()) * 1e6, 1),
        "worst_lateness_ms": round(worst_lag * 1e3, 3),
    }


def max_realtime(seconds: float, n_max: int = 64, ts: float = TS, method: str = "tustin",
                 dtype: str = "float64") -> tuple[int, list[dict]]:
    """Largest N in 1..n_max holding real time (< 1 % late), by bisection; returns (N, probes)."""
    probes: list[dict] = []

    def ok(n):
        res = realtime(n, seconds, ts, method, dtype)
        probes.append(res)
        return res["holds"]

    lo, hi = 0, n_max + 1  # lo holds (0 trivially), hi fails (n_max + 1 by convention)
    if ok(n_max):
        return n_max, probes
    hi = n_max
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return lo, probes


def machine() -> dict:
    model = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = os.cpu_count()
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "cpu_model": model,
        "cpu_count": os.cpu_count(),
        "cpu_affinity": affinity,
        "python": platform.python_version(),
        "python_impl": platform.python_implementation(),
        "numpy": np.__version__,
        "gc_enabled": gc.isenabled(),
    }


def run(ns=(1, 4, 16, 50), offline_s: float = 1.0, realtime_s: float = 3.0, n_max: int = 64,
        goal: int = 50, method: str = "tustin", dtype: str = "float64", scheduling: str = "default") -> dict:
    """The whole benchmark as a JSON-able dict (the core function; ``main`` prints it)."""
    load0 = os.getloadavg()
    steps = {str(n): offline(n, offline_s, method, dtype) for n in ns}
    xs = np.array([float(n) for n in ns])
    ys = np.array([steps[str(n)]["us_per_step_with_wire"] for n in ns])
    if len(ns) >= 2:
        slope, icpt = np.polyfit(xs, ys, 1)
    else:
        slope, icpt = steps[str(ns[0])]["wire_us_per_instance"], ys[0] - steps[str(ns[0])]["wire_us_per_instance"]
    bound = int(max(0.0, (TS * 1e6 - icpt) / slope)) if slope > 0 else None
    n_rt, probes = max_realtime(realtime_s, n_max, TS, method, dtype)
    at_goal = next((p for p in probes if p["n"] == goal), None)
    if at_goal is None and goal <= n_max:
        at_goal = realtime(goal, realtime_s, TS, method, dtype)
    load1 = os.getloadavg()
    return {
        "benchmark": "sdc_throughput",
        "machine": {**machine(), "loadavg_1min_before": round(load0[0], 2), "loadavg_1min_after": round(load1[0], 2)},
        "parameters": {
            "ts_s": TS,
            "method": method,
            "dtype": dtype,
            "villas_header": True,
            "ns": list(ns),
            "offline_s_per_measurement": offline_s,
            "realtime_s_per_probe": realtime_s,
            "late_limit_fraction": LATE_LIMIT,
            "search_range": [1, n_max],
            "bank_capacity": "N + 1 (as the service)",
            "measurement_samples_cycled": N_SAMPLES,
            "sockets_included": False,
            "scheduling": scheduling,
        },
        "steps_per_s": steps,
        "round_cost_fit_us": {"per_round": round(float(icpt), 1), "per_instance": round(float(slope), 2)},
        "n_offline_bound": bound,
        "max_instances_realtime": n_rt,
        "realtime_probes": probes,
        "goal_instances": goal,
        "goal_realtime": at_goal,
        "goal_met": bool(at_goal is not None and at_goal["holds"]),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="short run (~10 s): 0.25 s offline, 0.6 s per real-time probe")
    ap.add_argument("--method", default="tustin", choices=("tustin", "trapezoid_cumulative", "euler", "hold"))
    ap.add_argument("--dtype", default="float64", choices=("float64", "float32"))
    ap.add_argument("--rt-priority", action="store_true",
                    help="ask for SCHED_FIFO 10 as the service does (sdvisc.netns.raise_priority; root only)")
    args = ap.parse_args(argv)
    sched = "default"
    if args.rt_priority:
        from sdvisc.netns import raise_priority

        sched = raise_priority()
    kw = dict(method=args.method, dtype=args.dtype, scheduling=sched)
    if args.quick:
        res = run(offline_s=0.25, realtime_s=0.6, **kw)
    else:
        res = run(**kw)
    print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
