"""The coupler's wire protocol, version 2: a pure-Python twin of coupler/src/wire.cpp and
messages.cpp (docs/coupler.md is the normative description).

Every message is a 32-byte header and a payload, little-endian, floats IEEE-754 binary64::

    offset size field
     0     4   magic b"TQCP"
     4     2   protocol version (u16) = 2
     6     2   message type (u16)
     8     8   sequence number (u64): per direction, 0 first, +1 per message
    16     8   payload length (u64)
    24     4   CRC-32 of the payload (zlib.crc32)
    28     4   CRC-32 of header bytes 0..27

Byte compatibility with the C++ library is checked by both test suites against the shared
vectors in tests/data/coupler/vectors_v3.txt (made by :func:`write_test_vectors`).
"""

from __future__ import annotations

import enum
import math
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MAGIC = b"TQCP"
PROTOCOL_VERSION = 3
HEADER_SIZE = 32
MAX_HANDSHAKE_PAYLOAD = 1 << 30
MAX_STRING = 1 << 16

_HEADER = struct.Struct("<4sHHQQI")  # 28 bytes, then the header CRC


class MessageType(enum.IntEnum):
    HELLO = 1
    WELCOME = 2
    REJECT = 3
    READY = 4
    DATA = 10
    BYE = 20
    ABORT = 21


class ReasonCode(enum.IntEnum):
    WRONG_TOKEN = 1
    WRONG_VERSION = 2
    CONFIG_MISMATCH = 3
    MESH_MISMATCH = 4
    PROTOCOL_VIOLATION = 5
    SOLVER_ERROR = 6
    TIMEOUT = 7
    DIVERGED = 8


FLAG_CONVERGED = 1
FLAG_LAST_WINDOW = 2

SCHEMES = ("explicit", "paper", "implicit")
ACCELERATIONS = ("none", "constant", "aitken", "iqn-ils")
PREDICTORS = ("constant", "linear")
MAP_KINDS = ("coincident", "projection")
CONSTRAINTS = ("consistent", "conservative")


# ----------------------------------------------------------------------------- errors
class CouplerError(RuntimeError):
    """Base of every coupler error (the C++ CouplerError)."""


class ConfigError(CouplerError):
    pass


class ProtocolError(CouplerError):
    """A malformed, corrupted, foreign or out-of-order message. `fault` is one of
    bad_magic, bad_version, bad_header_crc, unknown_type, bad_length, bad_sequence,
    bad_payload_crc, bad_payload, unexpected_type (the names of the test vectors)."""

    def __init__(self, fault: str, message: str):
        super().__init__(message)
        self.fault = fault


class HandshakeError(CouplerError):
    pass


class TransportError(CouplerError):
    pass


class CouplingTimeoutError(TransportError):
    """Nothing (or not enough) arrived from the partner within the timeout (C++ TimeoutError)."""


class PartnerLostError(TransportError):
    """The partner went away: end of stream, reset, or it sent ABORT."""


class MapError(CouplerError):
    pass


class DivergenceError(CouplerError):
    pass


# ----------------------------------------------------------------------------- header
def crc32(data: bytes) -> int:
    return zlib.crc32(data) & 0xFFFFFFFF


@dataclass
class Header:
    version: int
    type: MessageType
    sequence: int
    payload_length: int
    payload_crc: int


def encode_header(mtype: int, sequence: int, payload: bytes) -> bytes:
    h = _HEADER.pack(MAGIC, PROTOCOL_VERSION, int(mtype), sequence, len(payload), crc32(payload))
    return h + struct.pack("<I", crc32(h))


def _printable(b: bytes) -> str:
    return "".join(chr(c) if 32 <= c < 127 else f"\\x{c:02x}" for c in b)


def decode_header(h: bytes) -> Header:
    """Validates magic, version, header CRC and type, in that order (as the C++ side)."""
    if len(h) < HEADER_SIZE:
        raise ProtocolError("bad_length", f"message of {len(h)} bytes is shorter than the 32-byte header")
    if h[:4] != MAGIC:
        raise ProtocolError(
            "bad_magic",
            f"not a TunnelQuake coupler message: it starts with '{_printable(h[:4])}' instead of 'TQCP' "
            "(a foreign program, or a partner that lost track of the message boundaries)",
        )
    magic, version, mtype, seq, length, pcrc = _HEADER.unpack_from(h)
    if version != PROTOCOL_VERSION:
        raise ProtocolError(
            "bad_version",
            f"coupler protocol version {version} received, this build speaks version {PROTOCOL_VERSION}: "
            "build both participants from the same TunnelQuake version",
        )
    if struct.unpack_from("<I", h, 28)[0] != crc32(h[:28]):
        raise ProtocolError("bad_header_crc", "message header corrupted (header CRC-32 mismatch)")
    try:
        t = MessageType(mtype)
    except ValueError:
        raise ProtocolError("unknown_type", f"unknown message type {mtype} in a protocol-version-1 header") from None
    return Header(version, t, seq, length, pcrc)


def frame(mtype: int, sequence: int, payload: bytes) -> bytes:
    return encode_header(mtype, sequence, payload) + payload


def unframe(msg: bytes) -> tuple[Header, bytes]:
    """Decodes one complete framed message: header, length == bytes present, payload CRC."""
    h = decode_header(msg)
    payload = msg[HEADER_SIZE:]
    if h.payload_length != len(payload):
        raise ProtocolError(
            "bad_length", f"header announces {h.payload_length} payload bytes, {len(payload)} present"
        )
    if crc32(payload) != h.payload_crc:
        raise ProtocolError("bad_payload_crc", f"{h.type.name} payload corrupted (payload CRC-32 mismatch)")
    return h, payload


# ----------------------------------------------------------------------------- payload codec
class Writer:
    def __init__(self) -> None:
        self.parts: list[bytes] = []

    def u8(self, v: int) -> None:
        self.parts.append(struct.pack("<B", v))

    def u32(self, v: int) -> None:
        self.parts.append(struct.pack("<I", v))

    def u64(self, v: int) -> None:
        self.parts.append(struct.pack("<Q", v))

    def f64(self, v: float) -> None:
        self.parts.append(struct.pack("<d", v))

    def str(self, s: str) -> None:
        b = s.encode("utf-8")
        if len(b) > MAX_STRING:
            raise ConfigError(f"string of {len(b)} bytes is too long for the coupler protocol (limit {MAX_STRING})")
        self.u32(len(b))
        self.parts.append(b)

    def f64s(self, a) -> None:
        self.parts.append(np.ascontiguousarray(a, dtype="<f8").tobytes())

    def i64s(self, a) -> None:
        self.parts.append(np.ascontiguousarray(a, dtype="<i8").tobytes())

    def i32s(self, a) -> None:
        self.parts.append(np.ascontiguousarray(a, dtype="<i4").tobytes())

    def bytes(self) -> bytes:
        return b"".join(self.parts)


class Reader:
    """Bounds-checked reader; any overrun or bad value raises ProtocolError('bad_payload')."""

    def __init__(self, data: bytes, what: str):
        self.b = memoryview(data)
        self.pos = 0
        self.what = what

    def fail(self, why: str):
        raise ProtocolError(
            "bad_payload", f"{self.what} payload does not decode at byte {self.pos} of {len(self.b)}: {why}"
        )

    def need(self, k: int) -> None:
        if k > len(self.b) - self.pos:
            self.fail(f"needs {k} more bytes, only {len(self.b) - self.pos} left (truncated)")

    def _unpack(self, fmt: str, size: int):
        self.need(size)
        v = struct.unpack_from(fmt, self.b, self.pos)[0]
        self.pos += size
        return v

    def u8(self) -> int:
        return self._unpack("<B", 1)

    def u32(self) -> int:
        return self._unpack("<I", 4)

    def u64(self) -> int:
        return self._unpack("<Q", 8)

    def f64(self) -> float:
        return self._unpack("<d", 8)

    def str(self) -> str:
        n = self.u32()
        if n > MAX_STRING:
            self.fail(f"string length {n} above the limit")
        self.need(n)
        s = bytes(self.b[self.pos : self.pos + n])
        self.pos += n
        try:
            return s.decode("utf-8")
        except UnicodeDecodeError:
            self.fail("string is not UTF-8")

    def count(self, element_size: int, name: str) -> int:
        c = self.u64()
        if element_size and c > (len(self.b) - self.pos) // element_size:
            self.fail(f"{name} count {c} does not fit in the {len(self.b) - self.pos} bytes left")
        return c

    def array(self, n: int, dtype: str) -> np.ndarray:
        size = np.dtype(dtype).itemsize * n
        self.need(size)
        a = np.frombuffer(self.b, dtype=dtype, count=n, offset=self.pos).astype(dtype[1:], copy=True)
        self.pos += size
        return a

    def enum(self, names: tuple[str, ...], what: str) -> str:
        v = self.u8()
        if v >= len(names):
            self.fail(f"{what} code {v} is not defined")
        return names[v]

    def finish(self) -> None:
        if self.pos != len(self.b):
            self.fail(f"{len(self.b) - self.pos} unexpected trailing bytes")


# ----------------------------------------------------------------------------- records
@dataclass
class MeshSpec:
    name: str
    mapping: str = "coincident"  # coincident | projection
    mapping_side: str = ""  # "" = the first participant
    tolerance: float = 1e-6  # m


@dataclass
class FieldSpec:
    mesh: str
    name: str
    components: int
    writer: str
    constraint: str = "consistent"  # consistent | conservative
    # implicit scheme: convergence floor on the RMS of the field's residual, in its units (0 = none)
    absolute_tolerance: float = 0.0


@dataclass
class CouplingConfig:
    """What both participants must agree on (the C++ CouplingConfig)."""

    first: str
    second: str
    window_size: float
    max_windows: int
    units: str = "SI(m,kg,s,N,Pa)"
    scheme: str = "implicit"
    max_iterations: int = 20
    tolerance: float = 1e-4
    acceleration: str = "aitken"
    initial_relaxation: float = 0.5
    meshes: list[MeshSpec] = field(default_factory=list)
    fields: list[FieldSpec] = field(default_factory=list)
    predictor: str = "constant"  # implicit: first iterate of a window, constant | linear (version 2)
    reuse: int = 0  # IQN-ILS: windows whose secant columns are kept (version 3)

    def mapping_side_of(self, m: MeshSpec) -> str:
        return m.mapping_side or self.first

    def partner_of(self, p: str) -> str:
        if p == self.first:
            return self.second
        if p == self.second:
            return self.first
        raise ConfigError(
            f"participant '{p}' is not in the coupling configuration (which has '{self.first}' and '{self.second}')"
        )

    def validate(self) -> None:
        def bad(m: str):
            raise ConfigError("coupling configuration: " + m)

        if not self.first or not self.second:
            bad("both participant names (first, second) are needed")
        if self.first == self.second:
            bad(f"the two participants have the same name '{self.first}'")
        if not (self.window_size > 0) or not np.isfinite(self.window_size):
            bad(f"window size must be a positive time in s, got {self.window_size}")
        if self.scheme not in SCHEMES:
            bad(f"unknown scheme '{self.scheme}': use explicit, paper or implicit")
        if self.acceleration not in ACCELERATIONS:
            bad(f"unknown acceleration '{self.acceleration}'")
        if self.scheme == "implicit" and (self.max_iterations < 2 or not self.tolerance > 0):
            bad("implicit scheme needs max iterations >= 2 and a positive tolerance")
        if not (0 < self.initial_relaxation <= 1):
            bad(f"initial relaxation must be in (0, 1], got {self.initial_relaxation}")
        if self.predictor not in PREDICTORS:
            bad(f"unknown predictor '{self.predictor}': use constant or linear")
        if self.predictor != "constant" and self.scheme != "implicit":
            bad(f"predictor {self.predictor} needs the implicit scheme (the {self.scheme} scheme has no iterations "
                "to start); use predictor constant")
        if not (0 <= self.reuse <= 1000):
            bad(f"reuse must be 0 to 1000 windows, got {self.reuse}")
        if self.reuse > 0 and (self.scheme != "implicit" or self.acceleration != "iqn-ils"):
            bad(f"reuse {self.reuse} keeps IQN-ILS columns: it needs scheme implicit and acceleration iqn-ils; "
                "use reuse 0")
        names = set()
        for m in self.meshes:
            if m.name in names:
                bad(f"mesh '{m.name}' declared twice")
            names.add(m.name)
            if m.mapping not in MAP_KINDS:
                bad(f"mesh '{m.name}': unknown map '{m.mapping}'")
            if m.mapping_side and m.mapping_side not in (self.first, self.second):
                bad(f"mesh '{m.name}': mapping side '{m.mapping_side}' is not a participant")
        seen = set()
        for f in self.fields:
            if f.mesh not in names:
                bad(f"field '{f.name}' on unknown mesh '{f.mesh}'")
            if (f.mesh, f.name) in seen:
                bad(f"field '{f.name}' on mesh '{f.mesh}' declared twice")
            seen.add((f.mesh, f.name))
            if not 1 <= f.components <= 9:
                bad(f"field '{f.name}': components must be 1..9")
            if f.writer not in (self.first, self.second):
                bad(f"field '{f.name}': writer '{f.writer}' is not a participant")
            if f.constraint not in CONSTRAINTS:
                bad(f"field '{f.name}': unknown constraint '{f.constraint}'")
            if not (f.absolute_tolerance >= 0 and math.isfinite(f.absolute_tolerance)):
                bad(f"field '{f.name}': absolute tolerance must be >= 0 and finite, got {f.absolute_tolerance}")


@dataclass
class MeshVertices:
    name: str
    ids: np.ndarray  # int64 [n]
    coordinates: np.ndarray  # float64 [n, 3]
    triangles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int32))

    def __post_init__(self):
        self.ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        self.coordinates = np.asarray(self.coordinates, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.asarray(self.triangles, dtype=np.int32).reshape(-1, 3)
        if len(self.coordinates) != len(self.ids):
            raise ConfigError(f"mesh '{self.name}': coordinates must be 3 per id")


@dataclass
class Hello:
    token: str
    participant: str
    partner: str
    config: CouplingConfig
    meshes: list[MeshVertices]


@dataclass
class Reason:
    code: int
    message: str


@dataclass
class FieldBlock:
    field: int
    components: int
    values: np.ndarray  # float64 [n * components], node-major


@dataclass
class DataMessage:
    window: int
    iteration: int
    flags: int
    time: float
    residual: float
    fields: list[FieldBlock]


def _encode_config(w: Writer, c: CouplingConfig) -> None:
    w.str(c.units)
    w.str(c.first)
    w.str(c.second)
    w.u8(SCHEMES.index(c.scheme))
    w.f64(c.window_size)
    w.u64(c.max_windows)
    w.u32(c.max_iterations)
    w.f64(c.tolerance)
    w.u8(ACCELERATIONS.index(c.acceleration))
    w.f64(c.initial_relaxation)
    w.u8(PREDICTORS.index(c.predictor))
    w.u32(c.reuse)
    w.u32(len(c.meshes))
    for m in c.meshes:
        w.str(m.name)
        w.u8(MAP_KINDS.index(m.mapping))
        w.str(m.mapping_side)
        w.f64(m.tolerance)
    w.u32(len(c.fields))
    for f in c.fields:
        w.str(f.mesh)
        w.str(f.name)
        w.u32(f.components)
        w.str(f.writer)
        w.u8(CONSTRAINTS.index(f.constraint))
        w.f64(f.absolute_tolerance)


def _decode_config(r: Reader) -> CouplingConfig:
    units, first, second = r.str(), r.str(), r.str()
    scheme = r.enum(SCHEMES, "scheme")
    window, maxw, maxit, tol = r.f64(), r.u64(), r.u32(), r.f64()
    acc = r.enum(ACCELERATIONS, "acceleration")
    relax = r.f64()
    pred = r.enum(PREDICTORS, "predictor")
    reuse = r.u32()
    if reuse > 1000:
        r.fail(f"reuse {reuse} above the limit 1000")
    nm = r.u32()
    if nm > 1024:
        r.fail(f"mesh count {nm} above the limit 1024")
    meshes = [MeshSpec(r.str(), r.enum(MAP_KINDS, "map kind"), r.str(), r.f64()) for _ in range(nm)]
    nf = r.u32()
    if nf > 4096:
        r.fail(f"field count {nf} above the limit 4096")
    fields = [FieldSpec(r.str(), r.str(), r.u32(), r.str(), r.enum(CONSTRAINTS, "map constraint"), r.f64())
              for _ in range(nf)]
    return CouplingConfig(first, second, window, maxw, units, scheme, maxit, tol, acc, relax, meshes, fields, pred,
                          int(reuse))


def encode_hello(h: Hello) -> bytes:
    w = Writer()
    w.str(h.token)
    w.str(h.participant)
    w.str(h.partner)
    _encode_config(w, h.config)
    w.u32(len(h.meshes))
    for m in h.meshes:
        w.str(m.name)
        w.u64(len(m.ids))
        w.i64s(m.ids)
        w.f64s(m.coordinates)
        w.u64(len(m.triangles))
        w.i32s(m.triangles)
    return w.bytes()


def decode_hello(payload: bytes) -> Hello:
    r = Reader(payload, "HELLO")
    token, participant, partner = r.str(), r.str(), r.str()
    config = _decode_config(r)
    nm = r.u32()
    if nm > 1024:
        r.fail("mesh count above the limit 1024")
    meshes = []
    for _ in range(nm):
        name = r.str()
        n = r.count(32, "node")
        ids = r.array(n, "<i8")
        xyz = r.array(3 * n, "<f8").reshape(n, 3)
        nt = r.count(12, "triangle")
        tri = r.array(3 * nt, "<i4").reshape(nt, 3)
        if tri.size and (tri.min() < 0 or tri.max() >= n):
            r.fail(f"mesh '{name}': triangle node index outside 0..{n}-1")
        meshes.append(MeshVertices(name, ids, xyz, tri))
    r.finish()
    return Hello(token, participant, partner, config, meshes)


def encode_reason(x: Reason) -> bytes:
    w = Writer()
    w.u32(int(x.code))
    b = x.message.encode("utf-8")[:MAX_STRING]
    w.u32(len(b))
    w.parts.append(b)
    return w.bytes()


def decode_reason(payload: bytes) -> Reason:
    r = Reader(payload, "REJECT/ABORT")
    x = Reason(r.u32(), r.str())
    r.finish()
    return x


def data_payload_size(values_per_block: list[int]) -> int:
    return 36 + sum(16 + 8 * v for v in values_per_block)


def encode_data(d: DataMessage) -> bytes:
    w = Writer()
    w.u64(d.window)
    w.u32(d.iteration)
    w.u32(d.flags)
    w.f64(d.time)
    w.f64(d.residual)
    w.u32(len(d.fields))
    for b in d.fields:
        v = np.ascontiguousarray(b.values, dtype=np.float64).reshape(-1)
        if b.components < 1 or v.size % b.components:
            raise ConfigError(f"DATA block of field #{b.field}: value count is not a multiple of the components")
        w.u32(b.field)
        w.u32(b.components)
        w.u64(v.size // b.components)
        w.f64s(v)
    return w.bytes()


def decode_data(payload: bytes) -> DataMessage:
    r = Reader(payload, "DATA")
    window, it, flags, time, res = r.u64(), r.u32(), r.u32(), r.f64(), r.f64()
    nb = r.u32()
    if nb > 4096:
        r.fail("block count above the limit 4096")
    blocks = []
    for i in range(nb):
        fi, comps = r.u32(), r.u32()
        if not 1 <= comps <= 9:
            r.fail(f"block {i}: {comps} components (1..9 allowed)")
        n = r.count(8 * comps, "node")
        blocks.append(FieldBlock(fi, comps, r.array(n * comps, "<f8")))
    r.finish()
    return DataMessage(window, it, flags, time, res, blocks)


def decode_message(msg: bytes):
    """Unframes and decodes a complete message: returns (header, record)."""
    h, payload = unframe(msg)
    if h.type in (MessageType.HELLO, MessageType.WELCOME):
        return h, decode_hello(payload)
    if h.type in (MessageType.REJECT, MessageType.ABORT, MessageType.BYE):
        return h, decode_reason(payload)
    if h.type == MessageType.READY:
        if payload:
            raise ProtocolError("bad_payload", "READY payload must be empty")
        return h, None
    return h, decode_data(payload)


# ----------------------------------------------------------------------------- test vectors
VECTOR_FILE = "vectors_v3.txt"


def sample_config() -> CouplingConfig:
    return CouplingConfig(
        first="solid",
        second="fluid",
        window_size=1e-4,
        max_windows=1000,
        scheme="implicit",
        max_iterations=20,
        tolerance=1e-4,
        acceleration="iqn-ils",
        initial_relaxation=0.5,
        predictor="linear",
        reuse=8,
        meshes=[MeshSpec("wall", "coincident", "solid", 1e-6)],
        fields=[
            FieldSpec("wall", "velocity", 3, "solid", "consistent", 1e-9),
            FieldSpec("wall", "force", 3, "fluid", "conservative", 0.25),
        ],
    )


def sample_messages() -> list[tuple[str, bytes]]:
    """The well-formed messages of the test vectors; coupler tests in C++ build the same ones
    (tests/cpp/coupler/test_wire.cpp, sampleMessages) and must produce identical bytes."""
    xyz = [[4.5, 0.0, 0.0], [0.0, 0.0, 4.5], [-4.5, 0.0, 0.0]]
    hello = Hello("run-7f3a", "solid", "fluid", sample_config(),
                  [MeshVertices("wall", [1000, 1001, 1002], xyz, [[0, 1, 2]])])
    welcome = Hello("run-7f3a", "fluid", "solid", sample_config(),
                    [MeshVertices("wall", [500002, 500001, 500000], xyz[::-1])])
    data = DataMessage(12, 1, FLAG_CONVERGED, 0.0013, 2.5e-5, [
        FieldBlock(0, 3, np.array([0.1, -0.2, 0.3, 1e-300, -0.0, 12345.678, -1.5e10, 2.0**-20, 7.0])),
    ])
    return [
        ("hello", frame(MessageType.HELLO, 0, encode_hello(hello))),
        ("welcome", frame(MessageType.WELCOME, 0, encode_hello(welcome))),
        ("ready", frame(MessageType.READY, 1, b"")),
        ("reject", frame(MessageType.REJECT, 0, encode_reason(Reason(ReasonCode.WRONG_TOKEN, "wrong token")))),
        ("data", frame(MessageType.DATA, 5, encode_data(data))),
        ("bye", frame(MessageType.BYE, 7, encode_reason(Reason(ReasonCode.SOLVER_ERROR, "")))),
        ("abort", frame(MessageType.ABORT, 9, encode_reason(Reason(ReasonCode.SOLVER_ERROR,
                                                                  "solid stopped: diverged \u00fc")))),
    ]


def _reheader(msg: bytes, version: int | None = None, mtype: int | None = None) -> bytes:
    """The message with header fields changed and the header CRC made valid again."""
    h = bytearray(msg[:28])
    if version is not None:
        struct.pack_into("<H", h, 4, version)
    if mtype is not None:
        struct.pack_into("<H", h, 6, mtype)
    return bytes(h) + struct.pack("<I", crc32(bytes(h))) + msg[32:]


def _repayload(msg: bytes, payload: bytes) -> bytes:
    """The message with another payload and a consistent header (length, CRCs)."""
    h = decode_header(msg)
    return frame(h.type, h.sequence, payload)


def malformed_messages() -> list[tuple[str, str, bytes]]:
    """(name, expected fault, bytes): every one must be refused with that fault."""
    good = dict(sample_messages())
    data = good["data"]
    payload = data[32:]
    flipped_seq = bytearray(data)
    flipped_seq[9] ^= 0x01
    flipped_payload = bytearray(data)
    flipped_payload[40] ^= 0x80
    hello_payload = bytearray(good["hello"][32:])
    # scheme code: after token, participant, partner, units, first, second strings
    r = Reader(bytes(hello_payload), "HELLO")
    for _ in range(6):
        r.str()
    hello_payload[r.pos] = 7
    return [
        ("foreign_http", "bad_magic", b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n"),
        ("bad_magic", "bad_magic", b"TQCX" + data[4:]),
        ("bad_version", "bad_version", _reheader(data, version=PROTOCOL_VERSION + 1)),
        ("bad_header_crc", "bad_header_crc", bytes(flipped_seq)),
        ("unknown_type", "unknown_type", _reheader(data, mtype=99)),
        ("truncated", "bad_length", data[:-8]),
        ("short_header", "bad_length", data[:20]),
        ("bad_payload_crc", "bad_payload_crc", bytes(flipped_payload)),
        ("truncated_payload", "bad_payload", _repayload(data, payload[:-8])),
        ("trailing_bytes", "bad_payload", _repayload(data, payload + b"\0\0\0\0")),
        ("huge_count", "bad_payload", _repayload(data, payload[:36] + struct.pack("<IIQ", 0, 3, 1 << 60))),
        ("bad_enum", "bad_payload", _repayload(good["hello"], bytes(hello_payload))),
        ("ready_with_payload", "bad_payload", frame(MessageType.READY, 1, b"x")),
    ]


def write_test_vectors(directory: str | Path) -> Path:
    """Writes tests/data/coupler/vectors_v3.txt: `name expect hex` lines."""
    out = Path(directory) / VECTOR_FILE
    lines = [
        f"# TunnelQuake coupler protocol v{PROTOCOL_VERSION} test vectors: name, expected outcome (ok or the fault), message hex.",
        "# Generated by tunnelquake.coupling.protocol.write_test_vectors; read by",
        "# tests/cpp/coupler/test_wire.cpp and tests/python/test_coupling_protocol.py.",
    ]
    for name, msg in sample_messages():
        lines.append(f"{name} ok {msg.hex()}")
    for name, fault, msg in malformed_messages():
        lines.append(f"{name} {fault} {msg.hex()}")
    out.write_text("\n".join(lines) + "\n")
    return out


def read_test_vectors(path: str | Path) -> list[tuple[str, str, bytes]]:
    rows = []
    for line in Path(path).read_text().splitlines():
        if not line or line.startswith("#"):
            continue
        name, expect, hexs = line.split()
        rows.append((name, expect, bytes.fromhex(hexs)))
    return rows


if __name__ == "__main__":  # python -m tunnelquake.coupling.protocol DIR
    import sys

    print(write_test_vectors(sys.argv[1] if len(sys.argv) > 1 else "."))
