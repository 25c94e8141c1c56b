"""The os-ken application: a thin shim between OpenFlow events and :class:`sdn_app.logic.Controller`.

It translates events into calls on the pure controller (passing the clock), sends back the
messages the controller asks for, counts controller↔switch messages, and writes the tables,
counters and events to the state directory for the runner, the CLI and users.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import socket
import threading
from collections import Counter
from pathlib import Path

from os_ken.base import app_manager
from os_ken.controller import ofp_event
from os_ken.controller.handler import CONFIG_DISPATCHER, MAIN_DISPATCHER, set_ev_cls
from os_ken.lib import hub
from os_ken.ofproto import ofproto_v1_3

from sdn_app import timer
from sdn_app.flows import Barrier
from sdn_app.logic import Controller
from sdn_app.ofmsg import to_messages
from sdn_app.redundancy import RoleState
from sdvisc import wire
from sdvisc.config import AppConfig, load_config
from sdvisc.latest_writer import LatestWriter
from sdvisc.netns import udp_socket_in

CONFIG_ENV = "SDVISC_SDN_CONFIG"
ROLE_ENV = "SDVISC_SDN_ROLE"  # master | slave | equal (default: equal, a single controller)
INSTANCE_ENV = "SDVISC_SDN_INSTANCE"  # 1 or 2: file names and event source
PEER_ENV = "SDVISC_SDN_PEER"  # "listen_port:send_port" on 127.0.0.1 for the peer heartbeat
STOPPING = False  # set by the launcher's SIGTERM handler: no more decisions while shutting down
PUBLISH_S = 0.1
INTAKE_BATCH = 256  # datagrams taken from the intake socket per decision at most
INTAKE_POLL_MS = 100  # the intake thread looks at STOPPING this often while nothing arrives


class SdviscApp(app_manager.OSKenApp):
    """os-ken shim for the SDViSC SDN application."""

    OFP_VERSIONS = [ofproto_v1_3.OFP_VERSION]

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.config = load_config(AppConfig, os.environ[CONFIG_ENV])
        self.clock = self.config.clock()  # the run's one clock: every decision is in simulated seconds
        now = self.clock.now()
        self.logic = Controller(self.config, now=now)
        self.datapaths: dict[int, object] = {}
        self.of_counts: Counter = Counter()
        self.instance = int(os.environ.get(INSTANCE_ENV, "1"))
        self.prefix = "sdn" if self.instance == 1 else f"sdn{self.instance}"
        self.roles = RoleState(role=os.environ.get(ROLE_ENV, "equal"), t_start=now)
        self._peer_sock = None
        self._peer_send = None
        if os.environ.get(PEER_ENV):
            listen, send = (int(x) for x in os.environ[PEER_ENV].split(":"))
            self._peer_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self._peer_sock.bind(("127.0.0.1", listen))
            self._peer_sock.setblocking(False)
            self._peer_send = ("127.0.0.1", send)
        self._last_peer_tx = 0.0
        self.state_dir = Path(self.config.state_dir) if self.config.state_dir else None
        if self.state_dir:
            self.state_dir.mkdir(parents=True, exist_ok=True)
            self._events_file = open(self.state_dir / f"{self.prefix}_events.jsonl", "a", buffering=1)  # noqa: SIM115
            # sdn_state.json is written off the event loop: a busy disk must not hold up packet-ins
            self._state_writer = LatestWriter(self.state_dir / f"{self.prefix}_state.json")
        else:
            self._events_file = None
        self._last_publish = 0.0
        self._barriers: dict[tuple[int, int], str] = {}  # (dpid, xid) -> path tag, until the reply
        # os-ken's default hub is "native": the timer below and the OpenFlow event handlers run in
        # separate OS threads. Every decision of the controller is taken under this lock, with the
        # clock read inside it (a tick preempted into the middle of a port-status handling once saw
        # a healed turbine half-restored and declared a second no_path for it)
        self._lock = threading.RLock()
        self.thread_ids: dict[str, int] = {}  # the app's own threads' kernel ids (sdn_state.json: per-thread CPU)
        self.intake_counts: Counter = Counter()
        self._intake = None
        if self.config.intake_socket is not None:  # AKs, heartbeats, requests and replies come here, not as packet-ins
            self._intake = udp_socket_in(self.config.intake_socket.netns_pid, self.config.controller_vip,
                                         wire.PORT_CONTROLLER, rcvbuf=1 << 22)
            self._intake_thread = hub.spawn(self._intake_loop)
        self._timer = hub.spawn(self._timer_loop)  # ends when STOPPING is set

    # ------------------------------------------------------------------ plumbing
    def _decide(self, decide, *args) -> None:
        """One decision of the controller, ``decide(*args, now)``, under the app's lock, its
        messages sent and events written before the next one is taken."""
        with self._lock:
            self._send(decide(*args, self.clock.now()))

    def _send(self, actions) -> None:
        if not self.roles.sends:
            self.of_counts["suppressed_as_slave"] += len(actions)
            self._flush_events()
            return
        for action in actions:
            dp = self.datapaths.get(action.dpid)
            if dp is None:
                self.of_counts["unsent_no_switch"] += 1
                continue
            for msg in to_messages(action, dp):
                dp.send_msg(msg)
                self.of_counts[f"tx_{type(msg).__name__}"] += 1
                self.of_counts["tx_total"] += 1
                if isinstance(action, Barrier):  # send_msg gave it its xid: the reply carries the same
                    self._barriers[(dp.id, msg.xid)] = action.tag
        self._flush_events()

    def _flush_events(self) -> None:
        events = self.logic.take_events()
        if self._events_file:
            for event in events:
                if not self.roles.sends:
                    event["shadow"] = True  # decided by the slave, not sent
                self._events_file.write(json.dumps(event) + "\n")

    def _publish(self, final: bool = False) -> None:
        """Hand the state to the writer: compact JSON while running (json's C encoder; the indented
        form takes its pure-Python encoder, ~1 ms per state on the event loop), indented at the end
        (``final``: from :meth:`stop`, which has taken the lock or given up waiting for it)."""
        if not self.state_dir or self._state_writer is None:  # (None: stopped, the last state written)
            return
        with self._lock if not final else contextlib.nullcontext():  # a consistent snapshot; encoding needs no lock
            state = {"tables": self.logic.snapshot(), "counters": dict(self.logic.counters),
                     "role": self.roles.role, "generation": self.roles.generation, "instance": self.instance,
                     "openflow": dict(self.of_counts), "intake": dict(self.intake_counts), "threads": dict(self.thread_ids), "wire": self.logic.wire_stats.as_dict(),
                     "t_wall": self.clock.now()}
        layout = {"indent": 1} if final else {"separators": (",", ":")}
        self._state_writer.put(json.dumps(state, sort_keys=True, **layout).encode())

    def _peer(self, now: float) -> None:
        """Peer heartbeat: the master announces itself; a slave takes over when it goes silent."""
        if self._peer_sock is None:
            return
        if self.roles.role == "master" and now - self._last_peer_tx >= self.roles.heartbeat_s:
            self._last_peer_tx = now
            try:
                self._peer_sock.sendto(f"sdvisc-master {self.roles.generation}".encode(), self._peer_send)
            except OSError:
                pass
        while True:
            try:
                data, _ = self._peer_sock.recvfrom(256)
            except (BlockingIOError, OSError):
                break
            parts = data.decode(errors="replace").split()
            if len(parts) == 2 and parts[0] == "sdvisc-master" and parts[1].isdigit():
                self.roles.on_peer_heartbeat(int(parts[1]), now)
        if self.roles.should_take_over(now):
            generation = self.roles.take_over()
            for dp in self.datapaths.values():
                self._request_role(dp)
            self.logic.event(now, "controller_takeover", instance=self.instance, generation=generation,
                              t_last_peer=self.roles.t_peer)
            self._flush_events()

    def _request_role(self, dp) -> None:
        ofp, parser = dp.ofproto, dp.ofproto_parser
        role = {"master": ofp.OFPCR_ROLE_MASTER, "slave": ofp.OFPCR_ROLE_SLAVE}.get(self.roles.role)
        if role is None:
            return
        dp.send_msg(parser.OFPRoleRequest(dp, role, self.roles.generation))
        self.of_counts["tx_OFPRoleRequest"] += 1
        if self.roles.role == "slave":  # receive what the master receives, to keep the same state
            pin = (1 << ofp.OFPR_NO_MATCH) | (1 << ofp.OFPR_ACTION)
            ps = (1 << ofp.OFPPR_ADD) | (1 << ofp.OFPPR_DELETE) | (1 << ofp.OFPPR_MODIFY)
            dp.send_msg(parser.OFPSetAsync(dp, [pin, pin], [ps, ps], [0, 0]))
            self.of_counts["tx_OFPSetAsync"] += 1

    def _intake_loop(self) -> None:
        """The intake socket: every datagram waiting at a wake-up is one decision of the controller."""
        sock, poller = self._intake, select.poll()
        self.thread_ids["intake"] = threading.get_native_id()
        poller.register(sock, select.POLLIN)
        while not STOPPING:
            if not poller.poll(INTAKE_POLL_MS):
                continue
            batch = []
            while len(batch) < INTAKE_BATCH:
                try:
                    data, (src_ip, _port) = sock.recvfrom(2048)
                except OSError:  # nothing more waiting (or an error the next poll sees again)
                    break
                batch.append((src_ip, data))
            if not batch:
                continue
            self.intake_counts["rx"] += len(batch)
            self.intake_counts["wakeups"] += 1
            try:
                self._decide(self.logic.delivered, batch)
            except Exception:  # noqa: BLE001 - a failed decision is logged and counted; the intake goes on
                self.intake_counts["decision_errors"] += 1
                self.logger.exception("intake: a decision on %d datagrams failed", len(batch))

    def _timer_loop(self) -> None:
        self.thread_ids["timer"] = threading.get_native_id()
        while not STOPPING:
            with self._lock:
                now = self.clock.now()
                self._peer(now)
                self._send(self.logic.tick(now))
                next_at = self.logic.next_decision_at(now) if self._peer_sock is None else now  # (a peer: every tick)
            if now - self._last_publish >= PUBLISH_S:  # (only this thread reads or sets _last_publish)
                self._last_publish = now
                self._publish()
            hub.sleep(self.clock.wall_s(timer.wait_s(now, next_at, self._last_publish + PUBLISH_S)))

    def stop(self):
        """Publish the final state and events before os-ken tears the app down."""
        # the timer may be stuck in a send to a switch that is gone: do not wait for it forever
        locked = self._lock.acquire(timeout=1.0)
        try:
            self._flush_events()
            self._publish(final=True)
            if self.state_dir:  # the last state written; a write interrupted by a signal may have left its temporary file
                if self._state_writer is not None:
                    self._state_writer.close()
                    self._state_writer = None
                for stray in self.state_dir.glob(f"{self.prefix}_state.json.{os.getpid()}.*.tmp"):
                    stray.unlink(missing_ok=True)
            if self._events_file:
                self._events_file.close()
                self._events_file = None
        finally:
            if locked:
                self._lock.release()
            super().stop()

    # ------------------------------------------------------------------ OpenFlow events
    @set_ev_cls(ofp_event.EventOFPSwitchFeatures, CONFIG_DISPATCHER)
    def _features(self, ev):
        dp = ev.msg.datapath
        self.of_counts["rx_features"] += 1
        with self._lock:
            self.datapaths[dp.id] = dp
            self._request_role(dp)
            self._decide(self.logic.switch_up, dp.id)
            # at once, not at the next PUBLISH_S of simulated time (1.6 s of wall at k = 16): the runner
            # waits for every switch in sdn_state.json before t = 0
            self._publish()

    @set_ev_cls(ofp_event.EventOFPPacketIn, MAIN_DISPATCHER)
    def _packet_in(self, ev):
        msg = ev.msg
        self.of_counts["rx_packet_in"] += 1
        self.of_counts["rx_total"] += 1
        self._decide(self.logic.packet_in, msg.datapath.id, msg.match.get("in_port", 0), msg.data)

    @set_ev_cls(ofp_event.EventOFPPortStatus, MAIN_DISPATCHER)
    def _port_status(self, ev):
        msg = ev.msg
        ofp = msg.datapath.ofproto
        self.of_counts["rx_port_status"] += 1
        self.of_counts["rx_total"] += 1
        desc = msg.desc
        up = not (desc.state & ofp.OFPPS_LINK_DOWN) and not (desc.config & ofp.OFPPC_PORT_DOWN)
        if msg.reason == ofp.OFPPR_DELETE:
            up = False
        self._decide(self.logic.port_status, msg.datapath.id, desc.port_no, up)

    @set_ev_cls(ofp_event.EventOFPBarrierReply, MAIN_DISPATCHER)
    def _barrier_reply(self, ev):
        msg = ev.msg
        self.of_counts["rx_barrier_reply"] += 1
        self.of_counts["rx_total"] += 1
        with self._lock:  # (the timer's sends fill _barriers)
            tag = self._barriers.pop((msg.datapath.id, msg.xid), None)
            if tag is not None:
                self._decide(self.logic.barrier_reply, msg.datapath.id, tag)

    @set_ev_cls(ofp_event.EventOFPEchoRequest, [CONFIG_DISPATCHER, MAIN_DISPATCHER])
    def _echo(self, ev):
        self.of_counts["rx_echo_keepalive"] += 1
