"""State files (sdn_state.json, plant_status.json) are replaced atomically: concurrent writers and
a reader polling them never produce or see a partial or mixed file, and nothing is left behind."""

from __future__ import annotations

import json
import threading

from sdvisc.jsonlines import write_json_atomic


def test_concurrent_writers_and_a_reader_never_see_a_broken_file(tmp_path):
    path = tmp_path / "state.json"
    write_json_atomic(path, {"writer": -1, "pad": ""})
    broken, stop = [], threading.Event()

    def writer(k):
        for i in range(300):
            write_json_atomic(path, {"writer": k, "i": i, "pad": "x" * ((k * 37 + i) % 500)})

    def reader():
        while not stop.is_set():
            try:
                json.loads(path.read_text())
            except ValueError as exc:
                broken.append(str(exc))

    threads = [threading.Thread(target=writer, args=(k,)) for k in range(4)]
    r = threading.Thread(target=reader)
    r.start()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    stop.set()
    r.join()
    assert not broken
    assert json.loads(path.read_text())["i"] == 299
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.json"]
