"""What a stand-in server (host_tools/servers.py) runs: its init script (private mounts, its own Open
vSwitch database and daemons, then sshd), its sshd configuration and keys, and openssh-server
installed if missing."""

from __future__ import annotations

import os
import shutil
import subprocess
import uuid
from pathlib import Path

OVS_SCHEMA = "/usr/share/openvswitch/vswitch.ovsschema"
SSHD = "/usr/sbin/sshd"


def ensure_sshd() -> None:
    """Install openssh-server if missing (Debian), without ever starting the system's ssh service."""
    if os.path.exists(SSHD):
        return
    if not shutil.which("apt-get"):
        raise RuntimeError("sshd missing: install openssh-server")
    policy = Path("/usr/sbin/policy-rc.d")
    had_policy = policy.exists()
    if not had_policy:  # invoke-rc.d then starts no service during the install
        policy.write_text("#!/bin/sh\nexit 101\n")
        policy.chmod(0o755)
    try:
        env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
        subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", "openssh-server"],
                       check=True, capture_output=True, env=env, timeout=600)
    finally:
        if not had_policy:
            policy.unlink(missing_ok=True)


def init_script(name: str, ip: str, confdir: Path) -> str:
    """The server's init, run in its network namespace under ``unshare --mount --uts``: private tmpfs
    over /run (so /run/openvswitch and /run/sshd), /etc/openvswitch and /var/log/openvswitch; a fresh
    database; ovsdb-server and ovs-vswitchd with the flags ``ovs-ctl start`` uses; then ``sshd -D``
    as the long-lived process."""
    db = "/etc/openvswitch/conf.db"
    sock = "/run/openvswitch/db.sock"
    log = "/var/log/openvswitch"
    run = "/run/openvswitch"
    system_id = uuid.uuid4()
    lines = [
        "set -e",
        f"hostname {name}",
        f"mount -t tmpfs -o mode=0755 {name} /run",
        f"mkdir -p {run} /run/sshd",
        f"mount -t tmpfs -o mode=0755 {name} /etc/openvswitch",
        f"mount -t tmpfs -o mode=0755 {name} {log}",
        f"ovsdb-tool create {db} {OVS_SCHEMA}",
        f"ovsdb-server {db} -vconsole:emer -vsyslog:err -vfile:info --remote=punix:{sock}"
        " --private-key=db:Open_vSwitch,SSL,private_key --certificate=db:Open_vSwitch,SSL,certificate"
        " --bootstrap-ca-cert=db:Open_vSwitch,SSL,ca_cert"
        f" --no-chdir --log-file={log}/ovsdb-server.log --pidfile={run}/ovsdb-server.pid --detach --monitor",
        f"ovs-vsctl --no-wait -- init -- set Open_vSwitch . external-ids:system-id={system_id}"
        f" external-ids:hostname={name} external-ids:rundir={run}",
        "ulimit -n 65535 2>/dev/null || true",
        f"ovs-vswitchd unix:{sock} -vconsole:emer -vsyslog:err -vfile:info --mlockall"
        f" --no-chdir --log-file={log}/ovs-vswitchd.log --pidfile={run}/ovs-vswitchd.pid --detach --monitor",
        "ovs-vsctl --timeout=10 show > /dev/null",
        f"exec {SSHD} -D -e -f {confdir}/sshd_config",
    ]
    return "\n".join(lines) + "\n"


def sshd_config(ip: str, confdir: Path, authorized: Path) -> str:
    return "\n".join([
        f"ListenAddress {ip}",
        f"HostKey {confdir}/ssh_host_ed25519_key",
        f"AuthorizedKeysFile {authorized}",
        "PermitRootLogin prohibit-password",
        "PubkeyAuthentication yes",
        "PasswordAuthentication no",
        "KbdInteractiveAuthentication no",
        "UsePAM no",
        "StrictModes no",
        "UseDNS no",
        "PrintMotd no",
        "PidFile /run/sshd.pid",
        "MaxSessions 100",
        "MaxStartups 100:30:200",
        "AcceptEnv LANG LC_*",
        "Subsystem sftp internal-sftp",
    ]) + "\n"


def keygen(path: Path, comment: str) -> None:
    subprocess.run(["ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-C", comment, "-f", str(path)],
                   check=True, capture_output=True, timeout=30)
