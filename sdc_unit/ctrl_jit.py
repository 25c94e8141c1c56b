"""MEAS datagrams in, CTRL datagrams out, in one compiled call: the SDC's stepping on the
compiled Tustin engine, for one datagram as for fifty.

Why: the numpy way (decode into a record array, the vectorised step, pack the batch) costs some
40 µs of Python and numpy calls per round on warm caches and about three times that on the cold
caches of a service that sleeps between samples -- more than the Tustin arithmetic by two orders of
magnitude, and most rounds of an SDC with a few turbines hold one MEAS.

What: :func:`meas_to_ctrl` takes the admitted MEAS datagrams of one call of the service core
(:class:`sdc_unit.core.SdcCore`, in the order they were read) and, for each, reads its eight
measurements (big-endian float32, at their :data:`sdvisc.wire.LAYOUTS` positions) into the
controller's measurement matrix, advances that turbine with the same compiled sample as
:meth:`sdc_unit.engines.CompiledEngine.advance_slots` (:func:`sdc_unit.tustin_jit._advance_one`)
and writes its CTRL datagram (header, ``wt``, ``seq``, ``meas_seq``, the seven
:data:`sdvisc.vocabulary.CTRL_OUTPUTS`, ``flags``) into a byte buffer, with the checks of
:func:`sdvisc.wire.encode`. Several samples of one turbine are stepped one after the other. The
admission (wire checks, range, sequence gate) is the core's (:mod:`sdc_unit.admission`); this
module has no socket, no clock and no counters. A unit test holds its bytes to the numpy way
(:func:`sdc_unit.round.answer_rows`: ``step_round`` and ``wire_batch.encode_batch``).
"""

from __future__ import annotations

import hashlib
import inspect

import numpy as np
from numba import njit

from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS
from sdvisc.wire import HEADER_WORDS, LAYOUTS, WORD_BYTES, MsgType

from . import tustin_jit
from .answer import NOT_STEPPED, SENT, UNENCODABLE

_MEAS_NAMES = tuple(f.name for f in LAYOUTS[MsgType.MEAS])
_CTRL_NAMES = tuple(f.name for f in LAYOUTS[MsgType.CTRL])
_MEAS_AT = _MEAS_NAMES.index(MEAS_FIELDS[0])
"""Word (after the header) of the first measurement; MEAS_FIELDS are consecutive words."""
_N_MEAS = len(MEAS_FIELDS)
_CTRL_WORDS = len(_CTRL_NAMES)
_CTRL_WT, _CTRL_SEQ, _CTRL_MEAS_SEQ, _CTRL_FLAGS = (_CTRL_NAMES.index(n) for n in ("wt", "seq", "meas_seq", "flags"))
_MEAS_WT, _MEAS_SEQ = _MEAS_NAMES.index("wt"), _MEAS_NAMES.index("seq")
_CTRL_OUT_AT = _CTRL_NAMES.index(CTRL_OUTPUTS[0])
_N_OUT = len(CTRL_OUTPUTS)
_CTRL_TYPE = int(MsgType.CTRL)
_HEADER_BYTES = HEADER_WORDS * WORD_BYTES
_MEAS_BYTES, _CTRL_BYTES = len(_MEAS_NAMES) * WORD_BYTES, _CTRL_WORDS * WORD_BYTES
"""A MEAS and a CTRL datagram's length without the header."""

if _MEAS_NAMES[_MEAS_AT:_MEAS_AT + _N_MEAS] != MEAS_FIELDS:
    raise RuntimeError(f"MEAS layout {_MEAS_NAMES} does not hold {MEAS_FIELDS} as consecutive words")
if _CTRL_NAMES[_CTRL_OUT_AT:_CTRL_OUT_AT + _N_OUT] != CTRL_OUTPUTS or tustin_jit.OUT_ROWS[:_N_OUT] != CTRL_OUTPUTS:
    raise RuntimeError(f"CTRL layout {_CTRL_NAMES} / kernel rows {tustin_jit.OUT_ROWS} do not start with {CTRL_OUTPUTS}")


@njit
def _get_u32(data, at):
    return ((np.uint32(data[at]) << np.uint32(24)) | (np.uint32(data[at + 1]) << np.uint32(16))
            | (np.uint32(data[at + 2]) << np.uint32(8)) | np.uint32(data[at + 3]))


@njit
def _put_u32(out, at, word):
    out[at] = (word >> 24) & 0xFF
    out[at + 1] = (word >> 16) & 0xFF
    out[at + 2] = (word >> 8) & 0xFF
    out[at + 3] = word & 0xFF


def compiled_in_key() -> int:
    """What the kernel compiles in from other files (see :func:`sdc_unit.tustin_jit._entry`): the
    step's own sources and the datagram layouts."""
    text = inspect.getsource(tustin_jit) + repr(tustin_jit.compiled_in_key()) + repr(_MEAS_NAMES) + repr(_CTRL_NAMES)
    return int(hashlib.sha256(text.encode()).hexdigest()[:15], 16)


@njit
def _answer_one(X, C, K, F, M, R, MEM, ACTIVE, LAST, LIMITED, slot, data, at, with_header, out, to, CTRL_SEQ,
                flag_bits, hdr_sec, hdr_nsec, new, mem, res, word, value):
    """One admitted MEAS datagram (``data[at:]``) of turbine ``slot`` in, its CTRL written to ``out[to:]``;
    returns the code (see :func:`meas_to_ctrl`)."""
    if not ACTIVE[slot]:
        return NOT_STEPPED
    base = _HEADER_BYTES if with_header else 0
    for r in range(_N_MEAS):
        word[0] = _get_u32(data, at + base + (_MEAS_AT + r) * WORD_BYTES)
        M[r, slot] = value[0]
    if not tustin_jit._advance_one(X, C, K, F, M, R, MEM, slot, LAST, LIMITED, new, mem, res):
        return NOT_STEPPED
    ctrl_seq = CTRL_SEQ[slot] + 1
    CTRL_SEQ[slot] = ctrl_seq  # used, also when the answer then does not fit its words
    if with_header:
        if hdr_sec < 0 or hdr_sec > 0xFFFFFFFF or hdr_nsec < 0 or hdr_nsec > 0xFFFFFFFF or ctrl_seq < 0:
            return UNENCODABLE
        _put_u32(out, to, np.uint32(ctrl_seq & 0xFFFFFFFF))
        _put_u32(out, to + WORD_BYTES, np.uint32(hdr_sec))
        _put_u32(out, to + 2 * WORD_BYTES, np.uint32(hdr_nsec))
    flags = (1 if LIMITED[slot] else 0) | flag_bits
    if ctrl_seq > 2147483647 or flags < -2147483648 or flags > 2147483647:
        return UNENCODABLE
    to += base
    _put_u32(out, to, np.uint32(_CTRL_TYPE))
    _put_u32(out, to + _CTRL_WT * WORD_BYTES, _get_u32(data, at + base + _MEAS_WT * WORD_BYTES))
    _put_u32(out, to + _CTRL_SEQ * WORD_BYTES, np.uint32(ctrl_seq & 0xFFFFFFFF))
    _put_u32(out, to + _CTRL_MEAS_SEQ * WORD_BYTES, _get_u32(data, at + base + _MEAS_SEQ * WORD_BYTES))
    _put_u32(out, to + _CTRL_FLAGS * WORD_BYTES, np.uint32(flags & 0xFFFFFFFF))
    for r in range(_N_OUT):
        value[0] = np.float32(LAST[r, slot])  # rounded to nearest, as struct.pack(">f")
        if np.isinf(value[0]):  # finite (checked by the step) but beyond float32
            return UNENCODABLE
        _put_u32(out, to + (_CTRL_OUT_AT + r) * WORD_BYTES, word[0])
    return SENT


def _entry(compiled_in: int):
    @njit(cache=True)
    def meas_to_ctrl(X, C, K, F, M, R, MEM, ACTIVE, LAST, LIMITED, ROWS, data, with_header, out, CTRL_SEQ,
                     flag_bits, hdr_sec, hdr_nsec):
        """For each row j of ``ROWS`` (int64; in: the turbine's slot, out: the row's code), in order:
        advance that turbine on the j-th MEAS datagram of ``data`` (uint8, the datagrams one after
        the other; already admitted: finite and in range) and write its CTRL into the j-th
        :func:`sdc_unit.answer.ctrl_bytes` of ``out`` (at least that long): header (its ``seq``,
        ``hdr_sec``, ``hdr_nsec``) when ``with_header``, ``wt`` and ``meas_seq`` the MEAS's, ``seq`` =
        ``CTRL_SEQ[slot]`` + 1 (``CTRL_SEQ`` per slot, advanced in place for every stepped turbine),
        flags = limiter bit | ``flag_bits``. The codes: :data:`sdc_unit.answer.SENT`,
        ``NOT_STEPPED`` (no ``seq`` used) or ``UNENCODABLE`` (``seq`` used)."""
        n = ROWS.shape[0]
        if compiled_in == 0:  # never true (the key is a closure constant: see tustin_jit._entry)
            n = 0
        word = np.empty(1, dtype=np.uint32)
        value = word.view(np.float32)
        new = np.empty(X.shape[0], dtype=X.dtype)
        mem = np.empty(MEM.shape[0], dtype=X.dtype)
        res = np.empty(LAST.shape[0], dtype=X.dtype)
        meas_bytes = _MEAS_BYTES + (_HEADER_BYTES if with_header else 0)
        ctrl_bytes = _CTRL_BYTES + (_HEADER_BYTES if with_header else 0)
        for j in range(n):
            ROWS[j] = _answer_one(X, C, K, F, M, R, MEM, ACTIVE, LAST, LIMITED, ROWS[j], data, j * meas_bytes,
                                  with_header, out, j * ctrl_bytes, CTRL_SEQ, flag_bits, hdr_sec, hdr_nsec,
                                  new, mem, res, word, value)

    return meas_to_ctrl


meas_to_ctrl = _entry(compiled_in_key())
