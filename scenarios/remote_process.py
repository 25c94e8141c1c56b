"""A run's service on a Mininet host of another server (issue 30; scenarios/cluster_spec.py).

:class:`RemoteProcess` has the part of ``subprocess.Popen``'s interface the runner uses (``pid``,
``poll``, ``wait``, ``returncode``, ``stdin``, ``send_signal``, ``terminate``, ``kill``) for a
process started over ssh: ``sh -c 'echo $$ > PIDFILE; exec env VARS mnexec -a HOSTPID ARGS'`` on
the server, so the service runs in the host's namespaces with the run's environment, and its
server-side PID is known. Signals go to that PID over ssh (killing the local ssh client would leave
the service running: no terminal is allocated, so nothing hangs it up); its exit status comes back
as the ssh client's; its output goes to the local log through ssh; its CPU time is read from the
server's /proc. The PID file lies in the run's output directory, which the servers share
(docs/cluster.md).
"""

from __future__ import annotations

import shlex
import signal
import subprocess
import time
from pathlib import Path

from host_tools.child_signals import default_signals
from sdvisc.netns import stat_cpu_seconds

PASSED_ENV_PREFIXES = ("PYTHON", "SDVISC", "OPENBLAS", "NUMBA", "OMP")
"""Environment variables handed to a remote service (ssh does not pass the environment)."""
PID_TIMEOUT_S = 20.0


def remote_command(host_pid: int, args: list[str], env: dict[str, str], pidfile: Path, user: str = "root") -> str:
    """The shell command run on the server (see the module docstring); a user other than root runs
    it under ``sudo -n`` (password-less sudo, as Mininet's cluster mode needs)."""
    passed = " ".join(f"{k}={shlex.quote(v)}" for k, v in sorted(env.items()) if k.startswith(PASSED_ENV_PREFIXES))
    cmd = (f"echo $$ > {shlex.quote(str(pidfile))}; exec env {passed} mnexec -a {int(host_pid)} "
           f"{shlex.join(args)}")
    return cmd if user == "root" else f"sudo -n sh -c {shlex.quote(cmd)}"


def as_root(user: str, cmd: str) -> str:
    """``cmd`` for a server's shell reached as ``user``: under ``sudo -n`` unless root."""
    return cmd if user == "root" else f"sudo -n sh -c {shlex.quote(cmd)}"


def popen_in(host, args: list[str], *, env: dict[str, str], pidfile: Path, stdin=None, stdout=None, stderr=None):
    """``args`` in Mininet ``host``'s namespaces: a :class:`RemoteProcess` if the host is on another
    server (``pidfile``: where its PID goes), else the host's own ``popen``."""
    if getattr(host, "isRemote", False):
        return RemoteProcess(host, args, env=env, pidfile=pidfile, stdin=stdin, stdout=stdout, stderr=stderr)
    return host.popen(args, stdin=stdin, stdout=stdout, stderr=stderr, env=env)


class RemoteProcess:
    """``args`` in Mininet ``host``'s namespaces on its server (``host.isRemote``); ``pidfile``: where
    the server-side shell writes its PID (it becomes the service's by ``exec``)."""

    def __init__(self, host, args: list[str], *, env: dict[str, str], pidfile: Path, stdin=None, stdout=None,
                 stderr=None) -> None:
        self.host = host
        self.pidfile = Path(pidfile)
        self.pidfile.unlink(missing_ok=True)
        self.ssh = [a for a in host.server_ssh() if a != "-tt"]
        self.args = list(args)
        self._pid: int | None = None
        self.user = getattr(host, "user", "root") or "root"
        cmd = remote_command(host.pid, args, env, self.pidfile, self.user)
        self.proc = subprocess.Popen([*self.ssh, "sh", "-c", shlex.quote(cmd)], stdin=stdin, stdout=stdout,
                                     stderr=stderr, start_new_session=True, preexec_fn=default_signals)
        self.stdin = self.proc.stdin

    # ------------------------------------------------------------------ Popen's interface
    @property
    def pid(self) -> int:
        """The service's PID on its server (waits for the PID file; the ssh client's if it never came)."""
        if self._pid is None:
            deadline = time.monotonic() + PID_TIMEOUT_S
            while self._pid is None:
                try:
                    self._pid = int(self.pidfile.read_text().split()[0])
                except (OSError, ValueError, IndexError):
                    if self.proc.poll() is not None or time.monotonic() > deadline:
                        return self.proc.pid
                    time.sleep(0.01)
        return self._pid

    @property
    def returncode(self) -> int | None:
        return self.proc.returncode

    def poll(self) -> int | None:
        return self.proc.poll()

    def wait(self, timeout: float | None = None) -> int:
        return self.proc.wait(timeout=timeout)

    def send_signal(self, sig: int) -> None:
        if self.proc.poll() is not None:
            return
        pid = self.pid
        if pid == self.proc.pid:  # no PID from the server: the ssh client is all there is to signal
            self.proc.send_signal(sig)
            return
        try:
            subprocess.run([*self.ssh, as_root(self.user, f"kill -{int(sig)} {pid}")], capture_output=True, timeout=20,
                           stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            self.proc.kill()

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()

    def cpu_seconds(self) -> float | None:
        """User + system CPU seconds of the service, from the server's /proc (None if gone)."""
        if self.proc.poll() is not None:
            return None
        pid = self.pid
        try:
            res = subprocess.run([*self.ssh, f"cat /proc/{pid}/stat"], capture_output=True, text=True, timeout=20,
                                 stdin=subprocess.DEVNULL)
            return stat_cpu_seconds(res.stdout)
        except (subprocess.TimeoutExpired, ValueError):
            return None
