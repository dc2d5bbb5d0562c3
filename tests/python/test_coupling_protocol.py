"""Wire protocol v1 of the Python twin: the shared test vectors (also read by the C++ tests),
header validation and payload codecs."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from conftest import ROOT
from tunnelquake.coupling import protocol as P

VECTORS = ROOT / "tests" / "data" / "coupler" / P.VECTOR_FILE


def test_vector_file_is_what_the_generator_writes(tmp_path):
    # The committed vectors and the generator agree byte for byte (regenerate with
    # `python -m tunnelquake.coupling.protocol tests/data/coupler` after a protocol change).
    fresh = P.write_test_vectors(tmp_path)
    assert fresh.read_text() == VECTORS.read_text()


def test_well_formed_vectors_decode_and_re_encode_identically():
    rows = P.read_test_vectors(VECTORS)
    ok = {name: msg for name, expect, msg in rows if expect == "ok"}
    assert set(ok) == {"hello", "welcome", "ready", "reject", "data", "bye", "abort"}
    for name, msg in P.sample_messages():
        assert ok[name] == msg
        P.decode_message(msg)
    h, hello = P.decode_message(ok["hello"])
    assert h.type == P.MessageType.HELLO and h.sequence == 0
    assert hello.token == "run-7f3a" and hello.config == P.sample_config()
    assert hello.meshes[0].ids.tolist() == [1000, 1001, 1002]
    assert hello.meshes[0].triangles.tolist() == [[0, 1, 2]]
    h, d = P.decode_message(ok["data"])
    assert (h.sequence, d.window, d.iteration, d.flags) == (5, 12, 1, P.FLAG_CONVERGED)
    v = d.fields[0].values
    assert v[3] == 1e-300 and math.copysign(1.0, v[4]) == -1.0  # bit-exact, -0.0 kept
    assert len(ok["data"]) - 32 == P.data_payload_size([9])
    _, r = P.decode_message(ok["abort"])
    assert r.message == "solid stopped: diverged \u00fc"


@pytest.mark.parametrize("name,fault,msg", [r for r in P.read_test_vectors(VECTORS) if r[1] != "ok"],
                         ids=lambda x: x if isinstance(x, str) else None)
def test_malformed_vectors_are_refused_with_their_fault(name, fault, msg):
    with pytest.raises(P.ProtocolError) as e:
        P.decode_message(msg)
    assert e.value.fault == fault, str(e.value)
    assert len(str(e.value)) > 20


def test_crc_and_header_layout():
    assert P.crc32(b"123456789") == 0xCBF43926
    m = P.frame(P.MessageType.DATA, 0x0102030405060708, b"\x01\x02\x03\x04\x05")
    assert m[:4] == b"TQCP" and len(m) == 37
    assert struct.unpack_from("<HHQQ", m, 4) == (3, 10, 0x0102030405060708, 5)


def test_every_truncation_of_a_hello_is_refused():
    msg = dict(P.sample_messages())["hello"]
    payload = msg[32:]
    for n in range(len(payload)):
        with pytest.raises(P.ProtocolError) as e:
            P.decode_hello(payload[:n])
        assert e.value.fault == "bad_payload"


def test_foreign_bytes_are_named():
    with pytest.raises(P.ProtocolError, match="'GET '") as e:
        P.decode_header(b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
    assert e.value.fault == "bad_magic"


def test_data_round_trip_of_a_large_block():
    vals = np.random.default_rng(1).normal(size=6000)
    d = P.DataMessage(3, 0, 0, 0.004, math.nan, [P.FieldBlock(1, 3, vals)])
    back = P.decode_data(P.encode_data(d))
    assert np.array_equal(back.fields[0].values, vals) and math.isnan(back.residual)
