"""The newest-snapshot file written off the caller's thread (sdvisc/latest_writer.py)."""

from __future__ import annotations

import json
import threading

import pytest

from sdvisc.latest_writer import LatestWriter


def test_close_leaves_the_newest_snapshot_and_older_ones_may_be_skipped(tmp_path):
    path = tmp_path / "status.json"
    w = LatestWriter(path)
    for k in range(500):
        w.put(json.dumps({"k": k}).encode())
    w.close()
    assert json.loads(path.read_text()) == {"k": 499}
    assert w.written + w.skipped == 500 and w.written >= 1 and w.errors == 0
    assert [p.name for p in tmp_path.iterdir()] == ["status.json"]  # no temporary file left
    with pytest.raises(ValueError):
        w.put(b"{}")


def test_put_returns_while_the_disk_is_busy(tmp_path, monkeypatch):
    """A write that blocks (a busy file system) does not block the caller: put returns, and the
    writer catches up with the newest snapshot once the disk answers."""
    import sdvisc.latest_writer as lw

    gate, real_replace = threading.Event(), lw.os.replace

    def slow_replace(src, dst):
        gate.wait(5)
        real_replace(src, dst)

    monkeypatch.setattr(lw.os, "replace", slow_replace)
    path = tmp_path / "status.json"
    w = LatestWriter(path)
    w.put(b'{"k": 0}')
    done = threading.Event()
    threading.Thread(target=lambda: (w.put(b'{"k": 1}'), w.put(b'{"k": 2}'), done.set()), daemon=True).start()
    assert done.wait(2), "put waited for the disk"
    gate.set()
    w.close()
    assert json.loads(path.read_text()) == {"k": 2}


def test_a_failed_write_is_counted_and_the_next_one_succeeds(tmp_path):
    missing = tmp_path / "gone"
    missing.mkdir()
    w = LatestWriter(missing / "status.json")
    missing.rmdir()
    w.put(b"1")
    w.close()
    assert w.errors == 1 and w.written == 0
    missing.mkdir()
    w = LatestWriter(missing / "status.json")
    w.put(b"2")
    w.close()
    assert (missing / "status.json").read_text() == "2" and w.errors == 0
