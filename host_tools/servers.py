"""Stand-in servers on this machine, for Mininet's cluster mode (issue 30; docs/cluster.md).

Each server ``sdvisc-srv<i>`` is a network namespace plus a private mount (and UTS) namespace in
which its own Open vSwitch daemons (``ovsdb-server``, ``ovs-vswitchd``: own database, run and log
directories on tmpfs) and its own ``sshd`` run. The servers share a LAN, a switch of its own: the
namespace :data:`LAN_NETNS` holding a Linux bridge, a veth from each server (``eth0`` inside,
``sdvsrv<i>`` on the bridge) and one from the root namespace — the "head" machine where the runner and
the SDN app run — whose root end :data:`LAN_HEAD_INTF` gets the LAN's first address. Server ``i`` gets
the LAN's address ``10 + i``. The bridge is not in the root namespace because a host firewall there
(Docker's ``FORWARD DROP`` with ``br_netfilter`` loaded) would filter what crosses it; the head's own
traffic is local (INPUT/OUTPUT), as a real head's is.

The servers belong to the process that made them (its PID and start time are in the key directory):
while it lives, another process's :func:`leftovers` does not list them and its clean-up leaves them
(and their Mininet shells) alone; once it is gone they are leftovers.

Code that uses a server reaches it over ssh only (:attr:`Server.ssh`), as it would reach a real
machine: an ssh session lands in the server's namespaces and sees its private Open vSwitch. The key
that opens them is made per :func:`make_servers` call in a private temporary directory (never the
user's ``~/.ssh``).

:func:`remove_servers` removes everything: every process in a server's network or mount namespace
(found by namespace inode, not by name), the ssh clients that use the servers' key, the namespaces,
the LAN namespace (with its bridge and veths), the head's veth and the key directory. :func:`leftovers` lists what is there
(``sdvisc clean`` uses both: host_tools/cleanup.py).
"""

from __future__ import annotations

import glob
import ipaddress
import os
import re
import shlex
import shutil
import signal
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from host_tools.server_init import ensure_sshd, init_script, keygen, sshd_config
from sdvisc.netns import command_line

NETNS_PREFIX = "sdvisc-srv"
NETNS_RE = re.compile(rf"^{NETNS_PREFIX}\d+$")
LAN_NETNS = "sdvisc-lan"
"""The LAN's own namespace: its bridge :data:`LAN_BRIDGE` and the bridge ends of every veth."""
LAN_BRIDGE = "br0"
LAN_HEAD_INTF = "sdvlan0"
"""The head's (root namespace's) interface on the LAN; its peer ``head`` is on the bridge."""
VETH_RE = re.compile(r"^sdvsrv\d+$")
"""The bridge ends (in :data:`LAN_NETNS`) of the servers' LAN veths."""
SERVER_LAN_INTF = "eth0"
KEYDIR_PREFIX = "sdvisc-servers-"
OWNER_FILE = "owner"
VXLAN_OVERHEAD = 50
"""Bytes a VXLAN tunnel adds over IPv4: outer Ethernet 14 + IPv4 20 + UDP 8 + VXLAN 8."""
READY_TIMEOUT_S = 20.0
_INITS: list[subprocess.Popen] = []


def netns_name(index: int) -> str:
    return f"{NETNS_PREFIX}{index}"


def veth_name(index: int) -> str:
    return f"sdvsrv{index}"


@dataclass
class Server:
    """One stand-in server: reach it with :attr:`ssh` (or :meth:`run`) as a real machine."""

    name: str
    index: int
    ip: str
    key: str | None
    """The private key that opens the server (None: ssh's own keys and agent)."""
    user: str = "root"
    lan_mtu: int = 1500
    head_ip: str = ""
    """The head machine's (root namespace's) address on the servers' LAN."""
    ssh_options: list[str] = field(default_factory=list)

    def __post_init__(self):
        if not self.ssh_options:
            self.ssh_options = ssh_options(self.key)

    @property
    def dest(self) -> str:
        return f"{self.user}@{self.ip}"

    @property
    def ssh(self) -> list[str]:
        """The ssh command prefix: ``ssh -i KEY -o BatchMode=yes ... root@IP``."""
        return ["ssh", *self.ssh_options, self.dest]

    def run(self, cmd: str, timeout: float = 30, check: bool = False) -> subprocess.CompletedProcess:
        """Run the shell command ``cmd`` on the server over ssh (stdout and stderr captured, text)."""
        res = subprocess.run([*self.ssh, cmd], capture_output=True, text=True, timeout=timeout,
                             stdin=subprocess.DEVNULL)
        if check and res.returncode != 0:
            raise RuntimeError(f"{self.name}: {cmd!r} exited {res.returncode}: {res.stderr.strip()}")
        return res


def ssh_options(key: str | None) -> list[str]:
    """ssh options (no destination) that open a server with ``key`` (None: ssh's own keys and agent):
    no prompt, no known-hosts file."""
    with_key = ["-i", key, "-o", "IdentitiesOnly=yes"] if key else []
    return [*with_key, "-o", "BatchMode=yes", "-o", "StrictHostKeyChecking=no",
            "-o", "UserKnownHostsFile=/dev/null", "-o", "LogLevel=ERROR", "-o", "ConnectTimeout=5"]


def _ip(*args: str, check: bool = True) -> str:
    res = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)
    if check and res.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {res.stderr.strip()}")
    return res.stdout


def make_servers(n: int, lan: str = "10.250.0.0/24", mtu: int = 1500) -> list[Server]:
    """Make ``n`` servers ``sdvisc-srv1``… on the LAN ``lan`` (the head: its first address; server
    ``i``: address ``10 + i``), the LAN's MTU ``mtu``. Leftover servers of an earlier call are
    removed first. Returns when every server answers over ssh with its own Open vSwitch."""
    if not 1 <= n <= 50:
        raise ValueError(f"make_servers: 1..50 servers, not {n}")
    network = ipaddress.ip_network(lan)
    if network.num_addresses < 64:
        raise ValueError(f"make_servers: LAN {lan} too small")
    ensure_sshd()
    remove_servers()
    prefix = network.prefixlen
    head_ip = str(network.network_address + 1)
    keydir = Path(tempfile.mkdtemp(prefix=KEYDIR_PREFIX))
    os.chmod(keydir, 0o700)
    (keydir / OWNER_FILE).write_text(f"{os.getpid()} {_start_time(os.getpid())}\n")
    key = keydir / "id_ed25519"
    keygen(key, "sdvisc-servers")
    authorized = keydir / "authorized_keys"
    shutil.copy(f"{key}.pub", authorized)
    servers = []
    try:
        _ip("netns", "add", LAN_NETNS)
        lan = ("-n", LAN_NETNS)
        _ip(*lan, "link", "add", LAN_BRIDGE, "mtu", str(mtu), "type", "bridge", "stp_state", "0", "forward_delay", "0")
        _ip(*lan, "link", "set", LAN_BRIDGE, "up")
        _ip("link", "add", LAN_HEAD_INTF, "mtu", str(mtu), "type", "veth", "peer", "name", "head", "mtu", str(mtu),
            "netns", LAN_NETNS)
        _ip(*lan, "link", "set", "head", "master", LAN_BRIDGE, "up")
        _ip("addr", "add", f"{head_ip}/{prefix}", "dev", LAN_HEAD_INTF)
        _ip("link", "set", LAN_HEAD_INTF, "up")
        for i in range(1, n + 1):
            name = netns_name(i)
            ip = str(network.network_address + 10 + i)
            confdir = keydir / name
            confdir.mkdir()
            keygen(confdir / "ssh_host_ed25519_key", name)
            (confdir / "sshd_config").write_text(sshd_config(ip, confdir, authorized))
            (confdir / "init.sh").write_text(init_script(name, ip, confdir))
            _ip("netns", "add", name)
            _ip(*lan, "link", "add", veth_name(i), "mtu", str(mtu), "type", "veth", "peer", "name", SERVER_LAN_INTF,
                "mtu", str(mtu), "netns", name)
            _ip(*lan, "link", "set", veth_name(i), "master", LAN_BRIDGE, "up")
            _ip("-n", name, "link", "set", "lo", "up")
            _ip("-n", name, "addr", "add", f"{ip}/{prefix}", "dev", SERVER_LAN_INTF)
            _ip("-n", name, "link", "set", SERVER_LAN_INTF, "up")
            with open(confdir / "init.log", "wb") as log:
                _INITS.append(subprocess.Popen(["ip", "netns", "exec", name, "unshare", "--mount", "--uts", "--propagation", "private",
                                  "sh", str(confdir / "init.sh")],
                                 stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
            servers.append(Server(name=name, index=i, ip=ip, key=str(key), lan_mtu=mtu, head_ip=head_ip))
        deadline = time.monotonic() + READY_TIMEOUT_S
        for server in servers:
            while True:
                try:
                    res = server.run("ovs-vsctl --timeout=5 get Open_vSwitch . external-ids:hostname", timeout=10)
                except subprocess.TimeoutExpired:
                    res = None
                if res is not None and res.returncode == 0 and server.name in res.stdout:
                    break
                if time.monotonic() > deadline:
                    log = (keydir / server.name / "init.log").read_text(errors="replace")
                    raise RuntimeError(f"{server.name} did not come up within {READY_TIMEOUT_S:.0f} s: "
                                       f"{res.stderr.strip() if res else 'ssh timed out'}; init log:\n{log}")
                time.sleep(0.1)
    except BaseException:
        remove_servers()
        raise
    return servers


def _ns_inode(path: str) -> int | None:
    try:
        return os.stat(path).st_ino
    except OSError:
        return None


def server_netns() -> list[str]:
    """The servers' namespaces, in order (not the LAN's: :func:`lan_netns`)."""
    return sorted((n for n in _ip("netns", "list", check=False).split() if NETNS_RE.match(n)),
                  key=lambda n: int(n[len(NETNS_PREFIX):]))


def lan_netns() -> list[str]:
    return [n for n in _ip("netns", "list", check=False).split() if n == LAN_NETNS]


def server_processes(only: str | None = None) -> list[tuple[int, str]]:
    """(pid, cmdline) of every process of the servers: those in a server's network namespace (by
    inode), those in the private mount namespace of a server's init (an ssh session's Mininet host
    shells live in namespaces of their own but in that mount namespace), and the ssh clients on the
    head that use a servers' key. This process and its parent are never listed. ``only``: the
    processes of that one server (its namespace's name), not the head's ssh clients."""
    names = [only] if only else server_netns() + lan_netns()
    net_inodes = {i for n in names if (i := _ns_inode(f"/run/netns/{n}"))}
    shared_mnt = {_ns_inode("/proc/1/ns/mnt"), _ns_inode("/proc/self/ns/mnt")}
    own = {os.getpid(), os.getppid()}
    entries = [int(e) for e in os.listdir("/proc") if e.isdigit()]
    mnt_inodes = set()
    for pid in entries:
        if _ns_inode(f"/proc/{pid}/ns/net") in net_inodes:
            mnt = _ns_inode(f"/proc/{pid}/ns/mnt")
            if mnt not in shared_mnt:
                mnt_inodes.add(mnt)
    mnt_inodes.discard(None)
    found = []
    for pid in entries:
        if pid in own:
            continue
        cmd = command_line(pid)
        if not cmd:  # gone, or a kernel thread
            continue
        mine = (_ns_inode(f"/proc/{pid}/ns/net") in net_inodes or _ns_inode(f"/proc/{pid}/ns/mnt") in mnt_inodes
                or (not only and cmd.startswith(("ssh ", "ssh:")) and f"/{KEYDIR_PREFIX}" in cmd))  # "ssh: PATH [mux]"
        if mine:
            found.append((pid, cmd))
    return found


def key_dirs() -> list[str]:
    return sorted(glob.glob(os.path.join(tempfile.gettempdir(), f"{KEYDIR_PREFIX}*")))


def server_links() -> list[str]:
    """The head's LAN interface in the root namespace (and, from older versions, a bridge or veth
    ends left there)."""
    names = []
    for line in _ip("-o", "link", "show", check=False).splitlines():
        parts = line.split(":")
        if len(parts) >= 2:
            name = parts[1].strip().split("@")[0]
            if name == LAN_HEAD_INTF or VETH_RE.match(name):
                names.append(name)
    return names


def _start_time(pid: int) -> int | None:
    """The start time of process ``pid`` (clock ticks since boot), None if it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return int(fh.read().rsplit(")", 1)[1].split()[19])
    except (OSError, IndexError, ValueError):
        return None


def owner() -> int | None:
    """The live process that made the servers (:func:`make_servers` records its PID and start time
    in the key directory), or None: no servers, or their maker is gone (they are left over)."""
    for d in key_dirs():
        try:
            pid, start = (int(x) for x in Path(d, OWNER_FILE).read_text().split())
        except (OSError, ValueError):
            continue
        if _start_time(pid) == start:
            return pid
    return None


def in_use_elsewhere() -> bool:
    """True while the servers belong to another live process (a test or run in progress): then
    they are not leftovers, and the clean-up of any other process leaves them alone."""
    pid = owner()
    return pid is not None and pid != os.getpid()


def protected_pids() -> set[int]:
    """The servers' processes while :func:`in_use_elsewhere` (host_tools.cleanup spares them)."""
    return {pid for pid, _ in server_processes()} if in_use_elsewhere() else set()


def leftovers(include_in_use: bool = False) -> list[str]:
    """What is there of the servers: namespaces, links, processes (``pid cmd``) and key directories;
    nothing while they belong to another live process, unless ``include_in_use``."""
    if not include_in_use and in_use_elsewhere():
        return []
    return ([f"netns {n}" for n in server_netns() + lan_netns()] + [f"link {n}" for n in server_links()]
            + [f"process {pid} {cmd[:80]}" for pid, cmd in server_processes()]
            + [f"keydir {d}" for d in key_dirs()])


def remove_servers(leftovers_only: bool = False) -> list[str]:
    """Remove every server: kill their processes (a few rounds, for children forked meanwhile),
    delete the veths, the servers' and the LAN's namespaces and the key directories. Returns what was there.
    ``leftovers_only`` (the clean-up's call): nothing while another live process owns them."""
    if leftovers_only and in_use_elsewhere():
        return []
    found = leftovers(include_in_use=True)
    for _round in range(10):
        procs = server_processes()
        if not procs:
            break
        for pid, _cmd in procs:
            try:
                os.kill(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        deadline = time.monotonic() + 2
        while time.monotonic() < deadline and any(os.path.exists(f"/proc/{p}") and not _zombie(p) for p, _ in procs):
            time.sleep(0.02)
    _reap()
    for name in server_links():
        _ip("link", "del", name, check=False)
    for name in server_netns() + lan_netns():
        _ip("netns", "del", name, check=False)
    for d in key_dirs():
        shutil.rmtree(d, ignore_errors=True)
    return found


def kill_server(name: str) -> list[int]:
    """The loss of one server (its namespace's name): SIGKILL to every process of it, in rounds (a
    dying parent may fork); its namespaces stay until :func:`remove_servers`. Returns the PIDs."""
    killed: list[int] = []
    for _round in range(5):
        procs = server_processes(only=name)
        if not procs:
            break
        for pid, _cmd in procs:
            try:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            except (ProcessLookupError, PermissionError):
                pass
        time.sleep(0.05)
    return killed


def _zombie(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] == "Z"
    except (OSError, IndexError):
        return True


def _reap() -> None:
    """Collect the servers' inits this process started (they have been killed)."""
    for proc in list(_INITS):
        try:
            proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            continue
        _INITS.remove(proc)


def tunnel_mtu(lan_mtu: int) -> int:
    """The MTU of a VXLAN tunnel over a LAN of ``lan_mtu`` (never above Ethernet's 1500)."""
    return min(1500, lan_mtu - VXLAN_OVERHEAD)


def quoted(cmd: list[str]) -> str:
    return " ".join(shlex.quote(c) for c in cmd)
