"""Interactive sessions on the real testbed: `sdvisc run --cli` driven through a pty (the farm stays
live after the timeline, a path link taken down from the CLI, the CLI's own recovery line, `exit`),
and the live view (`--web`) in headless Chromium (the ViSC path, then the failed link in red) and
its refusal of anything but localhost."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.integration.helpers import ROOT, TEST_TIME_SCALE, assert_no_leftovers, time_scale_args

pytestmark = pytest.mark.network
pexpect = pytest.importorskip("pexpect", reason="pexpect (test extra) drives the CLI through a pty")

CHROMIUM = "/usr/bin/chromium"
K = float(TEST_TIME_SCALE)
SMOKE = ROOT / "scenarios" / "smoke.yaml"  # wt1_1 on sdc1-s1-s3-l2-wt1_1 from t = 1 s; the timeline ends at 3 s
PROMPT = "sdvisc> "
NS, VETH_ROOT, VETH_NS = "sdvisc-webtest", "vwebt0", "vwebt1"
ROOT_IP, NS_IP = "10.250.0.1", "10.250.0.2"  # our own namespace's link (no other network is touched)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_session(out: Path, *extra: str):
    child = pexpect.spawn(sys.executable, ["-m", "scenarios.cli", "run", str(SMOKE), "--out", str(out), "--cli",
                                           "--cli-duration", "200", *time_scale_args(), *extra],
                          cwd=str(ROOT), encoding="utf-8", timeout=120 * K, dimensions=(50, 250),
                          env=dict(os.environ, PYTHONUNBUFFERED="1", TERM="xterm"))
    child.expect(PROMPT)
    return child


def command(child, line: str, pattern: str, timeout_s: float = 30.0) -> re.Match:
    child.sendline(line)
    child.expect(pattern, timeout=timeout_s * K)
    return child.match


def status(child) -> tuple[float, str, str]:
    """Simulated time, the links this run took down and those the SDN app has seen down, from `status`
    (read to its last line: nothing stale left behind)."""
    match = command(child, "status", r"t_sim=(\d+\.\d+) s.*?down links: (.*?) \(seen by the SDN app: (.*?)\)"
                                     r"   openflow: [^\n]*\n")
    return float(match.group(1)), match.group(2), match.group(3)


def simulated_time(child) -> float:
    return status(child)[0]


def wait_past(child, t_s: float) -> float:
    t = simulated_time(child)
    while t < t_s:
        time.sleep(0.5)
        t = simulated_time(child)
    return t


def end_session(child) -> None:
    child.sendline("exit")
    child.expect(pexpect.EOF, timeout=120 * K)
    child.close()
    assert child.exitstatus == 0, child.before


def first_switch_link(path: list[str]) -> tuple[str, str]:
    switches = [n for n in path if re.fullmatch(r"s\d+", n)]
    return switches[0], switches[1]


def take_down_a_path_link(child, a: str, b: str, tries: int = 2) -> tuple[str, str]:
    """Take link a-b of wt1_1's path down from the CLI and wait for its recovery line; returns the
    link taken down. A busy machine (here: Chromium starting) can make the SDN app reroute on missing
    acknowledgements just before the command: the link then carries nothing and the feedback says so;
    the link stays down and the first switch link of the new path is taken down instead."""
    for _ in range(tries):
        child.sendline(f"link {a} {b} down")
        if child.expect(["restored after", rf"link {a}-{b} down: no ViSC turbine lost"], timeout=30 * K) == 0:
            return a, b
        path = command(child, "paths", r"wt1_1: (sdc\d[\w >-]+?)\r?\n").group(1).split(" -> ")
        hops = "-".join(path)
        assert f"{a}-{b}" not in hops and f"{b}-{a}" not in hops, f"{a}-{b} down on the path {hops} and no loss"
        a, b = first_switch_link(path)
    raise AssertionError(f"wt1_1 moved off {tries} links before they were taken down")


def test_cli_session_stays_live_after_the_timeline_and_reports_the_recovery(tmp_path):
    out = tmp_path / "session"
    child = start_session(out)
    try:
        t = wait_past(child, 4.0)  # the scenario's 3 s are over: the farm is still live
        path = command(child, "paths", r"wt1_1: (sdc\d[\w >-]+?)\r?\n").group(1).split(" -> ")
        assert path[0] == "sdc1" and path[-1] == "wt1_1"
        a, b = first_switch_link(path)
        command(child, f"link {a} {b} down", rf"link {a}-{b} down")
        line = command(child, "", r"wt1_1: control lost at [\d.]+ s; DR at ([\d.]+) s; new path (\S+); "
                                  r"restored after (\d+) ms")
        t_dr, new_path, restored_ms = float(line.group(1)), line.group(2).split("-"), int(line.group(3))
        assert t_dr > t and f"{a}-{b}" not in "-".join(new_path) and f"{b}-{a}" not in "-".join(new_path)
        assert status(child)[1] == f"{a}-{b}"
        deadline = time.time() + 10 * K  # the SDN app publishes its tables every 0.1 s (simulated)
        while status(child)[2] != f"{a}-{b}":
            assert time.time() < deadline, "the SDN app's tables never showed the link down"
            time.sleep(0.2)
        # the event log has it all: the DR, then the turbine's control back (a loaded machine may log an
        # earlier ctrl_lost/ctrl_restored pair too: the first ctrl_restored is not necessarily the DR's)
        command(child, "events 50", r"sdn_app\s+dr\s+wt=wt1_1[\s\S]*?plant\s+ctrl_restored\s+wt=wt1_1")
        t_before_exit = simulated_time(child)
        end_session(child)
    finally:
        if child.isalive():
            child.terminate(force=True)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["completed"] and summary["duration_s"] >= t_before_exit  # the whole session
    (rec,) = [r for r in summary["recoveries"] if r["fault"]["type"] == "link_down"]
    assert rec["cause"] == "dr" and abs(rec["recovery_ms"] - restored_ms) <= 1.0  # the CLI said what summary says
    assert_no_leftovers()


def test_sigterm_ends_a_session_and_leaves_nothing(tmp_path):
    """Ctrl-C at the prompt only interrupts the line; SIGTERM (or a hang-up) ends the session."""
    child = start_session(tmp_path / "term")
    try:
        # the prompt's loop answers a command first: the start's prompt can come before the loop that
        # takes Ctrl-C runs (one pass sent the interrupt there and got a fresh prompt, no message)
        simulated_time(child)
        child.expect(PROMPT)
        child.sendintr()
        child.expect("type exit to end the session")
        t_after = simulated_time(child)  # still answering, and the session's time still moves:
        deadline = time.monotonic() + 60.0
        while simulated_time(child) <= t_after and time.monotonic() < deadline:
            time.sleep(0.5)
        assert simulated_time(child) > t_after, "the run stopped at the interrupt"
        child.kill(signal.SIGTERM)
        child.expect(pexpect.EOF, timeout=120 * K)
        child.close()
        assert child.exitstatus == 130, child.before
    finally:
        if child.isalive():
            child.terminate(force=True)
    assert json.loads((tmp_path / "term" / "summary.json").read_text())["completed"] is False
    assert_no_leftovers()


@pytest.fixture
def own_namespace():
    """A network namespace of this test with a veth to the root namespace (10.250.0.1 <-> .2)."""
    def ip(*args):
        subprocess.run(["ip", *args], check=True, capture_output=True)

    subprocess.run(["ip", "netns", "del", NS], capture_output=True)
    subprocess.run(["ip", "link", "del", VETH_ROOT], capture_output=True)
    ip("netns", "add", NS)
    try:
        ip("link", "add", VETH_ROOT, "type", "veth", "peer", "name", VETH_NS)
        ip("link", "set", VETH_NS, "netns", NS)
        ip("addr", "add", f"{ROOT_IP}/30", "dev", VETH_ROOT)
        ip("link", "set", VETH_ROOT, "up")
        ip("netns", "exec", NS, "ip", "addr", "add", f"{NS_IP}/30", "dev", VETH_NS)
        ip("netns", "exec", NS, "ip", "link", "set", VETH_NS, "up")
        ip("netns", "exec", NS, "ip", "link", "set", "lo", "up")
        yield NS
    finally:
        subprocess.run(["ip", "link", "del", VETH_ROOT], capture_output=True)
        subprocess.run(["ip", "netns", "del", NS], capture_output=True)


def http_get_from_namespace(ns: str, ip: str, port: int) -> str:
    """GET / from inside ``ns``: 'refused', 'closed' (accepted, then closed unanswered) or the status line."""
    code = ("import socket,sys\n"
            "s=socket.socket(); s.settimeout(5)\n"
            "try: s.connect((sys.argv[1], int(sys.argv[2])))\n"
            "except ConnectionRefusedError: print('refused'); sys.exit()\n"
            "s.sendall(b'GET / HTTP/1.1\\r\\nHost: 127.0.0.1\\r\\n\\r\\n')\n"
            "data=s.recv(200)\n"
            "print(data.split(b'\\r\\n')[0].decode() if data else 'closed')\n")
    res = subprocess.run(["ip", "netns", "exec", ns, sys.executable, "-c", code, ip, str(port)],
                         capture_output=True, text=True, timeout=30)
    return res.stdout.strip() or res.stderr.strip()


def test_live_view_answers_loopback_only(own_namespace):
    """Even bound to a non-loopback address (the testbed binds 127.0.0.1), the server answers only
    clients on the loopback, and only requests naming 127.0.0.1/localhost (no DNS rebinding)."""
    from scenarios.web import LiveView

    class Stub:  # a run and a session with nothing in them: the page itself is static
        links_down, events, lines, ended = set(), [], [], threading.Event()
        plant_status = sdn_state = staticmethod(dict)
        now = staticmethod(float)

    port = free_port()
    view = LiveView(Stub(), Stub(), port, host="0.0.0.0").start()
    try:
        assert http_get_from_namespace(own_namespace, ROOT_IP, port) == "closed"  # from 10.250.0.2: no answer
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(b"GET / HTTP/1.1\r\nHost: attacker.example:80\r\n\r\n")
            assert b" 403 " in s.recv(100)
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(f"POST /live HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 0\r\n\r\n".encode())
            assert b" 501 " in s.recv(100)  # nothing takes a request that could act
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
            assert b" 200 " in s.recv(100)
    finally:
        view.stop()


def test_live_view_in_chromium_shows_the_path_then_the_failed_link(tmp_path, own_namespace):
    if not Path(CHROMIUM).exists():
        pytest.skip(f"chromium is not installed ({CHROMIUM}); ./testbed installs the Debian package")
    playwright = pytest.importorskip("playwright.sync_api", reason="playwright (test extra) drives chromium")
    port = free_port()
    child = start_session(tmp_path / "web", "--web", str(port))
    url = f"http://127.0.0.1:{port}/"
    try:
        assert url in child.before
        # bound to 127.0.0.1: from our own namespace, the machine's side of its link refuses
        assert http_get_from_namespace(own_namespace, ROOT_IP, port) == "refused"
        wait_past(child, 1.5)  # wt1_1 runs as ViSC from t = 1 s
        with playwright.sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=[
                "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run"])
            try:
                page = browser.new_page(viewport={"width": 1400, "height": 1000})
                page.goto(url)
                wait_ms = 30_000 * K
                # the path the SDN app built for wt1_1 (sdc1-s1-s3-l2-wt1_1 unless a busy machine made it
                # reroute), shown in the table and highlighted in the drawing, both read in one snapshot of
                # the page (a loaded machine once rerouted twice between two separate reads of them)
                shown = page.wait_for_function("""() => {
                    const text = ((document.querySelector('#path-wt1_1') || {}).textContent || '').trim();
                    if (!/^sdc1-s\\d+-.*-wt1_1$/.test(text)) return false;
                    const lit = new Set([...document.querySelectorAll('#topology line.path')].map(l => l.dataset.link));
                    const hops = text.split('-');  // a link's data-link has its ends sorted by name
                    return hops.slice(1).every((hop, i) => lit.has([hops[i], hop].sort().join('-'))) && text;
                }""", timeout=wait_ms)
                hops = shown.json_value().split("-")
                assert page.locator("#topology line.down").count() == 0
                page.wait_for_function("() => document.querySelectorAll('#plots .uplot').length === 4", timeout=wait_ms)
                a, b = take_down_a_path_link(child, hops[1], hops[2])  # the first switch-to-switch link
                failed = "-".join(sorted((a, b)))
                page.wait_for_selector(f'#topology line.down[data-link="{failed}"]', state="attached",
                                       timeout=wait_ms)
                page.wait_for_function(f"() => !document.querySelector('#path-wt1_1').textContent"
                                       f".includes('{a}-{b}')", timeout=wait_ms)
                assert failed in page.inner_text("#down-links")
                # the plant reports control restored a few ms after the new path is in place: a
                # snapshot can fall between the two, so wait for the line rather than read it once
                page.wait_for_function("() => document.querySelector('#feedback').innerText"
                                       ".includes('restored after')", timeout=wait_ms)
                t1 = float(page.inner_text("#t"))
                page.wait_for_timeout(2000)
                assert float(page.inner_text("#t")) > t1  # still live
                page.screenshot(path=str(tmp_path / "live_view.png"), full_page=True)
            except Exception as exc:
                page.screenshot(path=str(tmp_path / "live_view_failed.png"), full_page=True)  # what the page showed
                raise AssertionError(f"{exc}\n--- the page showed:\n{page.inner_text('body')[:3000]}") from exc
            finally:
                browser.close()
        end_session(child)
    finally:
        if child.isalive():
            child.terminate(force=True)
    assert_no_leftovers()
