"""The runner → service command channel: complete JSON lines only, partial lines kept, EOF seen."""

from __future__ import annotations

import os

from sdvisc.jsonlines import JsonLineReader


def test_partial_lines_wait_for_their_end_and_eof_closes():
    r, w = os.pipe()
    reader = JsonLineReader(r)
    assert reader.read() == [] and reader.open  # nothing yet, no blocking
    os.write(w, b'{"type": "load_step", "mw": 50}\n{"type": "sc')
    assert reader.read() == [{"type": "load_step", "mw": 50}]
    os.write(w, b'r", "value": 1.51}\n\n')
    assert reader.read() == [{"type": "scr", "value": 1.51}]
    os.close(w)
    assert reader.read() == [] and not reader.open
    os.close(r)
