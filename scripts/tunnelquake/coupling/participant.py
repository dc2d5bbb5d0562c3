"""The coupling participant in pure Python: the twin of coupler/src/participant.cpp,
scheme.cpp and acceleration.cpp, speaking the same protocol (handshake, DATA, BYE/ABORT) so a
Python fake can stand in for either solver against the C++ library.

Maps: the coincident (1:1) map is implemented here; the projection map only in C++, so with a
projection map the C++ participant must be the mapping side (the default: the first, the solid).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .protocol import (
    FLAG_CONVERGED,
    FLAG_LAST_WINDOW,
    ConfigError,
    CouplerError,
    CouplingConfig,
    CouplingTimeoutError,
    DataMessage,
    DivergenceError,
    FieldBlock,
    HandshakeError,
    Hello,
    MapError,
    MeshVertices,
    MessageType,
    PartnerLostError,
    ProtocolError,
    Reason,
    ReasonCode,
    TransportError,
    data_payload_size,
    decode_data,
    decode_hello,
    decode_reason,
    encode_data,
    encode_hello,
    encode_reason,
)
from .transport import (
    Deadline,
    Endpoint,
    MpiChannel,
    MpiListener,
    MpiWorld,
    TcpListener,
    connect_tcp,
)


# ----------------------------------------------------------------------------- accelerations
class Acceleration:
    def start_window(self) -> None:
        pass

    def next(self, x: np.ndarray, xt: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class NoAcceleration(Acceleration):
    def next(self, x, xt):
        return xt.copy()


class ConstantRelaxation(Acceleration):
    def __init__(self, omega: float):
        self.omega = omega

    def next(self, x, xt):
        return x + self.omega * (xt - x)


class Aitken(Acceleration):
    def __init__(self, omega0: float):
        self.omega0 = self.omega = omega0
        self.r_prev = None

    def start_window(self):
        self.r_prev = None
        self.omega = self.omega0

    def next(self, x, xt):
        r = xt - x
        if self.r_prev is None:
            self.omega = self.omega0
        else:
            dr = r - self.r_prev
            den = float(dr @ dr)
            if den > 0:
                self.omega = -self.omega * float(self.r_prev @ dr) / den
            self.omega = max(-10.0, min(10.0, self.omega))
        self.r_prev = r
        return x + self.omega * r


class IqnIls(Acceleration):
    """IQN-ILS; with reuse > 0 the columns of the last `reuse` windows are kept (IQN-ILS(reuse)), as in
    coupler/src/acceleration.cpp."""

    def __init__(self, omega0: float, eps: float = 1e-10, reuse: int = 0):
        self.omega0, self.eps, self.reuse = omega0, eps, reuse
        self.dr: list[np.ndarray] = []
        self.dxt: list[np.ndarray] = []
        self.col_window: list[int] = []
        self.window = 0
        self.start_window()

    def _drop_oldest(self):
        self.dr.pop(0)
        self.dxt.pop(0)
        self.col_window.pop(0)

    def start_window(self):
        self.window += 1
        while self.dr and self.col_window[0] + self.reuse < self.window:
            self._drop_oldest()
        self.r_prev = None
        self.xt_prev = None

    def next(self, x, xt):
        r = xt - x
        if self.r_prev is not None:
            self.dr.append(r - self.r_prev)
            self.dxt.append(xt - self.xt_prev)
            self.col_window.append(self.window)
            if len(self.dr) > len(x):
                self._drop_oldest()
        fresh = self.r_prev is None and self.reuse == 0
        self.r_prev, self.xt_prev = r, xt.copy()
        while not fresh and self.dr:
            V = np.column_stack(self.dr)
            q, R = np.linalg.qr(V)
            if np.all(np.abs(np.diag(R)) >= self.eps * np.linalg.norm(V)) and np.linalg.norm(V) > 0:
                alpha = np.linalg.solve(R, -(q.T @ r))
                return xt + np.column_stack(self.dxt) @ alpha
            self._drop_oldest()
        return x + self.omega0 * r


def make_acceleration(kind: str, omega0: float, reuse: int = 0) -> Acceleration:
    if kind == "iqn-ils":
        return IqnIls(omega0, reuse=reuse)
    return {"none": NoAcceleration, "constant": ConstantRelaxation, "aitken": Aitken}[kind](
        *(() if kind == "none" else (omega0,))
    )


def relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    if a.shape != b.shape:
        return math.inf
    d, n = float(np.sum((a - b) ** 2)), float(np.sum(a * a))
    if n == 0:
        return 0.0 if d == 0 else math.inf
    return math.sqrt(d / n)


def convergence_measure(a: np.ndarray, b: np.ndarray, slices, tolerance: float) -> float:
    """Max over the fields of min(relative residual, tolerance * rms / absolute tolerance), the second
    term only where the field has an absolute tolerance (the C++ convergenceMeasure): a pass has
    converged when it is below the tolerance. slices: (offset, size, absolute tolerance) per field."""
    if a.shape != b.shape:
        return math.inf
    worst = 0.0
    for off, size, atol in slices:
        x, y = a[off : off + size], b[off : off + size]
        m = relative_difference(x, y)
        if atol > 0 and size > 0:
            m = min(m, tolerance * math.sqrt(float(np.sum((x - y) ** 2)) / size) / atol)
        worst = max(worst, m)
    return worst


# ----------------------------------------------------------------------------- maps
def coincident_permutation(source: np.ndarray, target: np.ndarray, tol: float, source_ids=None, target_ids=None):
    """perm[t] = source index paired with target node t; MapError listing unmatched nodes."""
    from scipy.spatial import cKDTree

    if len(source) != len(target):
        raise MapError(
            f"coincident (1:1) map needs the same number of nodes on both sides: source has {len(source)}, "
            f"target {len(target)} (use the projection map for non-matching meshes)"
        )
    d, idx = cKDTree(source).query(target)
    bad = np.flatnonzero(d > tol)
    counts = np.bincount(idx[d <= tol], minlength=len(source))
    doubled = np.flatnonzero(counts > 1)
    if len(bad) or len(doubled):
        lines = [f"coincident (1:1) map with tolerance {tol:g} m failed:"]
        if len(bad):
            lines.append(f" {len(bad)} of {len(target)} target nodes have no source node within the tolerance")
            for t in bad[:10]:
                tid = f" (id {target_ids[t]})" if target_ids is not None else ""
                lines.append(f"  target #{t}{tid} at {tuple(target[t])}: nearest source node is {d[t]:g} m away")
        if len(doubled):
            lines.append(f" {len(doubled)} source nodes pair with more than one target")
        raise MapError("\n".join(lines))
    return idx


# ----------------------------------------------------------------------------- participant
@dataclass
class SchemeState:
    window: int = 0
    iteration: int = 0
    ongoing: bool = True
    window_complete: bool = False
    write_checkpoint: bool = False
    read_checkpoint: bool = False
    residual: float = math.nan
    total_iterations: int = 0
    unconverged_windows: int = 0


class _Field:
    def __init__(self, index, spec, write, own_nodes, wire_nodes, perm_read=None, perm_write=None):
        self.index, self.spec, self.write = index, spec, write
        self.comps = spec.components
        self.own_nodes, self.wire_nodes = own_nodes, wire_nodes
        self.perm_read = perm_read  # own[i] = wire[perm_read[i]]
        self.perm_write = perm_write  # wire[j] = own[perm_write[j]]
        self.own = np.zeros((own_nodes, self.comps))  # written or read values on my nodes
        self.wire = np.zeros((wire_nodes, self.comps))


class Participant:
    """Python participant. Same call sequence as the C++ tq::coupler::Participant::

        p = Participant("fluid", config, token, address_file="run/wall.addr")
        p.set_mesh_vertices("wall", ids, xyz)
        p.initialize()
        while p.is_coupling_ongoing():
            if p.requires_writing_checkpoint(): ...
            v = p.read_data("wall", "velocity")
            p.write_data("wall", "force", f)
            p.advance(p.get_max_time_step_size())
            if p.requires_reading_checkpoint(): ...
        p.finalize()
    """

    def __init__(self, name: str, config: CouplingConfig, token: str, *, transport: str = "tcp",
                 address_file=None, listen: bool | None = None, bind: str = "127.0.0.1", port: int = 0,
                 connect_host: str = "127.0.0.1", connect_port: int = 0,
                 connect_timeout: float = 120.0, receive_timeout: float = 120.0):
        config.validate()
        self.name = name
        self.config = config
        self.partner = config.partner_of(name)
        self.first = name == config.first
        if not token:
            raise ConfigError(f"participant '{name}': an empty run token is not allowed")
        self.token = token
        self.transport = transport
        self.address_file = address_file
        self.listen = self.first if listen is None else listen
        self.bind, self.port = bind, port
        self.connect_host, self.connect_port = connect_host, connect_port
        self.connect_timeout, self.receive_timeout = connect_timeout, receive_timeout
        self.meshes: dict[str, MeshVertices] = {}
        self.partner_meshes: dict[str, MeshVertices] = {}
        self.link: Endpoint | None = None
        self.state = SchemeState()
        self.fields: list[_Field] = []
        self.initialized = self.finalized = False
        self.time_in_window = 0.0
        self.exchanges = 0
        self._mpi_world = None
        acc = config.acceleration if config.scheme == "implicit" else "none"
        self.acc = make_acceleration(acc, config.initial_relaxation, config.reuse)
        self.max_passes = {"explicit": 1, "paper": 2, "implicit": config.max_iterations}[config.scheme]
        self.test_convergence = config.scheme == "implicit"

    # ------------------------------------------------------------------ set-up
    def set_mesh_vertices(self, mesh: str, ids, coordinates, triangles=None) -> None:
        if mesh not in [m.name for m in self.config.meshes]:
            raise ConfigError(f"participant '{self.name}': mesh '{mesh}' is not in the coupling configuration")
        mv = MeshVertices(mesh, ids, coordinates, np.zeros((0, 3), np.int32) if triangles is None else triangles)
        if len(np.unique(mv.ids)) != len(mv.ids):
            raise ConfigError(f"participant '{self.name}', mesh '{mesh}': a node id appears more than once")
        self.meshes[mesh] = mv

    def _hello(self) -> Hello:
        return Hello(self.token, self.name, self.partner, self.config, [self.meshes[m.name] for m in self.config.meshes])

    def _check_partner(self, h: Hello) -> str:
        out = []
        if h.participant != self.partner:
            out.append(f"it is participant '{h.participant}', expected '{self.partner}'")
        if h.partner != self.name:
            out.append(f"it expects to couple with '{h.partner}', this is '{self.name}'")
        a, b = self.config, h.config
        for key in ("units", "first", "second", "scheme", "window_size", "max_windows", "max_iterations",
                    "tolerance", "acceleration", "initial_relaxation", "predictor", "reuse"):
            if getattr(a, key) != getattr(b, key):
                out.append(f"{key.replace('_', ' ')}: here {getattr(a, key)!r}, '{self.partner}' has {getattr(b, key)!r}")
        if len(a.meshes) != len(b.meshes):
            out.append(f"number of meshes: here {len(a.meshes)}, '{self.partner}' has {len(b.meshes)}")
        for x, y in zip(a.meshes, b.meshes, strict=False):
            if (x.name, x.mapping, a.mapping_side_of(x), x.tolerance) != (y.name, y.mapping, b.mapping_side_of(y), y.tolerance):
                out.append(f"mesh '{x.name}': here {x}, '{self.partner}' has {y}")
        if len(a.fields) != len(b.fields):
            out.append(f"number of fields: here {len(a.fields)}, '{self.partner}' has {len(b.fields)}")
        for x, y in zip(a.fields, b.fields, strict=False):
            if x != y:
                out.append(f"field '{x.name}': here {x}, '{self.partner}' has {y}")
        theirs = {m.name: m for m in h.meshes}
        for m in a.meshes:
            if m.name not in theirs:
                out.append(f"it sent no vertices for interface mesh '{m.name}'")
            elif m.mapping == "coincident" and len(theirs[m.name].ids) != len(self.meshes[m.name].ids):
                out.append(
                    f"interface mesh '{m.name}' has {len(self.meshes[m.name].ids)} nodes here and "
                    f"{len(theirs[m.name].ids)} on '{self.partner}'; a coincident (1:1) map needs equal counts "
                    "(use the projection map for non-matching meshes)"
                )
        return "".join("\n  - " + s for s in out)

    def _build_maps(self, h: Hello) -> None:
        self.partner_meshes = {m.name: m for m in h.meshes}
        perms = {}
        for m in self.config.meshes:
            if self.config.mapping_side_of(m) != self.name:
                continue
            if m.mapping != "coincident":
                raise MapError(
                    f"interface mesh '{m.name}': the Python participant implements only the coincident map; "
                    "let the C++ participant be the mapping side for the projection map"
                )
            own, theirs = self.meshes[m.name], self.partner_meshes[m.name]
            try:
                # partner node j pairs with my node perm[j]
                perms[m.name] = coincident_permutation(own.coordinates, theirs.coordinates, m.tolerance,
                                                       own.ids, theirs.ids)
            except MapError as e:
                raise MapError(f"interface mesh '{m.name}' between '{self.name}' and '{self.partner}': {e}") from None
        self.fields = []
        partner_blocks = []
        for i, spec in enumerate(self.config.fields):
            own_n = len(self.meshes[spec.mesh].ids)
            perm = perms.get(spec.mesh)
            wire_n = len(self.partner_meshes[spec.mesh].ids) if perm is not None else own_n
            inv = None
            if perm is not None:
                inv = np.empty_like(perm)
                inv[perm] = np.arange(len(perm))
            write = spec.writer == self.name
            f = _Field(i, spec, write, own_n, wire_n, perm_read=inv, perm_write=perm)
            self.fields.append(f)
            if not write:
                partner_blocks.append(wire_n * spec.components)
        self.partner_data_bytes = data_payload_size(partner_blocks)

    def _reject(self, ep: Endpoint, code: ReasonCode, text: str) -> None:
        try:
            ep.send(MessageType.REJECT, encode_reason(Reason(code, text)), Deadline(2.0), "handshake")
        except CouplerError:
            pass

    def _accept(self, deadline: Deadline) -> None:
        if self.transport == "mpi":
            listener = MpiListener(self._mpi_world)
        else:
            listener = TcpListener(self.name, self.partner, self.bind, self.port, self.address_file)
        refused = []
        try:
            while True:
                try:
                    ch = listener.accept(deadline)
                except CouplingTimeoutError as e:
                    raise CouplingTimeoutError(
                        f"{e} (connect timeout {deadline.seconds:g} s)" + "".join("\n  - refused: " + r for r in refused)
                    ) from None
                ep = Endpoint(ch, self.name, self.partner)
                # A silent connection must not hold the port: a real partner sends HELLO at once.
                hello_by = Deadline(min(10.0, max(0.0, deadline.remaining())))
                own_deadline = hello_by.at < deadline.at
                try:
                    hdr, payload = ep.receive(hello_by if own_deadline else deadline, "HELLO (handshake)")
                    if hdr.type != MessageType.HELLO:
                        raise ProtocolError("unexpected_type", f"a {hdr.type.name} message arrived where HELLO starts the handshake")
                    h = decode_hello(payload)
                except ProtocolError as e:
                    if e.fault == "bad_version":
                        self._reject(ep, ReasonCode.WRONG_VERSION, str(e))
                        raise HandshakeError(str(e)) from None
                    if not listener.can_accept_again:
                        raise
                    self._reject(ep, ReasonCode.PROTOCOL_VIOLATION, str(e))
                    refused.append(f"a foreign or malformed connection ({e})")
                    ep.close()
                    continue
                except TransportError as e:
                    if not listener.can_accept_again or (isinstance(e, CouplingTimeoutError) and not own_deadline):
                        raise
                    refused.append(f"a connection that closed before its HELLO ({e})")
                    continue
                if h.token != self.token:
                    text = (f"participant '{self.name}' refused the connection of '{h.participant}': its run token "
                            "differs (it belongs to another run, or the two sides were given different tokens)")
                    self._reject(ep, ReasonCode.WRONG_TOKEN, text)
                    ep.close()
                    if not listener.can_accept_again:
                        raise HandshakeError(text)
                    refused.append(f"'{h.participant}' with a different run token")
                    continue
                problems = self._check_partner(h)
                if problems:
                    text = f"participant '{self.name}' cannot couple with '{h.participant}': the configurations differ:{problems}"
                    self._reject(ep, ReasonCode.CONFIG_MISMATCH, text)
                    raise HandshakeError(text)
                try:
                    self._build_maps(h)
                except MapError as e:
                    self._reject(ep, ReasonCode.MESH_MISMATCH, str(e))
                    raise HandshakeError(str(e)) from None
                ep.send(MessageType.WELCOME, encode_hello(self._hello()), deadline, "handshake")
                hdr, payload = ep.receive(deadline, "READY (handshake)")
                if hdr.type == MessageType.REJECT:
                    raise HandshakeError(f"participant '{self.name}' was refused by its partner: {decode_reason(payload).message}")
                if hdr.type != MessageType.READY:
                    raise ProtocolError("unexpected_type", f"participant '{self.name}' expected READY, got {hdr.type.name}")
                self.link = ep
                return
        finally:
            listener.close()

    def _connect(self, deadline: Deadline) -> None:
        if self.transport == "mpi":
            ch = MpiChannel(self._mpi_world)
        else:
            ch = connect_tcp(self.name, self.partner, deadline, self.address_file, self.connect_host, self.connect_port)
        ep = Endpoint(ch, self.name, self.partner)
        self.link = ep
        ep.send(MessageType.HELLO, encode_hello(self._hello()), deadline, "handshake")
        try:
            hdr, payload = ep.receive(deadline, "WELCOME (handshake answer)")
        except ProtocolError as e:
            if e.fault == "bad_version":
                self._reject(ep, ReasonCode.WRONG_VERSION, str(e))
                raise HandshakeError(str(e)) from None
            self._reject(ep, ReasonCode.PROTOCOL_VIOLATION, str(e))
            raise
        if hdr.type == MessageType.REJECT:
            ep.close()
            raise HandshakeError(f"participant '{self.name}' was refused by its partner: {decode_reason(payload).message}")
        if hdr.type != MessageType.WELCOME:
            text = f"participant '{self.name}' expected WELCOME or REJECT, got {hdr.type.name}"
            self._reject(ep, ReasonCode.PROTOCOL_VIOLATION, text)
            raise ProtocolError("unexpected_type", text)
        h = decode_hello(payload)
        if h.token != self.token:
            text = f"participant '{self.name}' refused '{h.participant}': its run token differs (another run's participant)"
            self._reject(ep, ReasonCode.WRONG_TOKEN, text)
            raise HandshakeError(text)
        problems = self._check_partner(h)
        if problems:
            text = f"participant '{self.name}' cannot couple with '{h.participant}': the configurations differ:{problems}"
            self._reject(ep, ReasonCode.CONFIG_MISMATCH, text)
            raise HandshakeError(text)
        try:
            self._build_maps(h)
        except MapError as e:
            self._reject(ep, ReasonCode.MESH_MISMATCH, str(e))
            raise HandshakeError(str(e)) from None
        ep.send(MessageType.READY, b"", deadline, "handshake")

    def initialize(self) -> float:
        for m in self.config.meshes:
            if m.name not in self.meshes or len(self.meshes[m.name].ids) == 0:
                raise ConfigError(f"participant '{self.name}': interface mesh '{m.name}' has no vertices; call set_mesh_vertices() first")
        if self.transport == "mpi":
            self._mpi_world = MpiWorld(self.name, self.partner)
            if self._mpi_world.app.Get_rank() != 0:
                raise ConfigError(f"participant '{self.name}': only rank 0 of an application talks to the partner")
        deadline = Deadline(self.connect_timeout)
        try:
            self._accept(deadline) if self.listen else self._connect(deadline)
        except CouplerError:
            if self.link is not None:
                self.link.close()
            raise
        self.link.expected_data = self.partner_data_bytes
        self.initialized = True
        st = self.state
        st.ongoing = self.config.max_windows > 0
        st.write_checkpoint = st.ongoing and self.config.scheme != "explicit"
        self._guarded("initialize", self._scheme_initialize)
        return self.get_max_time_step_size()

    # ------------------------------------------------------------------ data
    def _field(self, mesh: str, name: str, write: bool, caller: str) -> _Field:
        if not self.initialized:
            raise ConfigError(f"participant '{self.name}': {caller} before initialize()")
        for f in self.fields:
            if f.spec.mesh == mesh and f.spec.name == name:
                if f.write != write:
                    raise ConfigError(f"participant '{self.name}': {caller} of field '{name}', which is "
                                      f"{'written' if f.write else 'read'} by this side")
                return f
        raise ConfigError(f"participant '{self.name}': {caller} of unknown field '{name}' on mesh '{mesh}'")

    def write_data(self, mesh: str, name: str, values) -> None:
        f = self._field(mesh, name, True, "write_data")
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        if v.size != f.own.size:
            raise ConfigError(f"participant '{self.name}': write_data of '{name}' with {v.size} values, expected {f.own.size}")
        if not np.all(np.isfinite(v)):
            text = f"participant '{self.name}' wrote a non-finite value of '{name}': the solution has blown up"
            self.abort(text)
            raise DivergenceError(text)
        f.own[:] = v.reshape(f.own.shape)

    def read_data(self, mesh: str, name: str) -> np.ndarray:
        """Partner's latest values on my nodes, shape [nodes, components]."""
        return self._field(mesh, name, False, "read_data").own.copy()

    def _written(self) -> np.ndarray:
        return np.concatenate([f.own.reshape(-1) for f in self.fields if f.write] or [np.zeros(0)])

    def _set_written(self, x: np.ndarray) -> None:
        o = 0
        for f in self.fields:
            if f.write:
                f.own[:] = x[o : o + f.own.size].reshape(f.own.shape)
                o += f.own.size

    def _slices(self, write: bool) -> list[tuple[int, int, float]]:
        """(offset, size, absolute tolerance) of the written (own layout) or received (wire) fields."""
        out, o = [], 0
        for f in self.fields:
            if f.write == write:
                n = (f.own if write else f.wire).size
                out.append((o, n, f.spec.absolute_tolerance))
                o += n
        return out

    def _received(self) -> np.ndarray:
        return np.concatenate([f.wire.reshape(-1) for f in self.fields if not f.write] or [np.zeros(0)])

    def _send(self, window: int, iteration: int, flags: int, residual: float) -> None:
        blocks = []
        for f in self.fields:
            if f.write:
                f.wire = f.own if f.perm_write is None else f.own[f.perm_write]
                blocks.append(FieldBlock(f.index, f.comps, f.wire.reshape(-1)))
        d = DataMessage(window, iteration, flags, (window + 1) * self.config.window_size, residual, blocks)
        self.link.send(MessageType.DATA, encode_data(d), Deadline(self.receive_timeout),
                       f"window {window + 1}, pass {iteration + 1}")

    def _receive(self, window: int, iteration: int):
        what = (f"DATA of window {window + 1} of {self.config.max_windows}, pass {iteration + 1} "
                f"(t = {(window + 1) * self.config.window_size:g} s)")
        hdr, payload = self.link.receive(Deadline(self.receive_timeout), what)
        if hdr.type == MessageType.BYE:
            raise PartnerLostError(f"'{self.partner}' ended the coupling (BYE) while '{self.name}' was waiting for {what}")
        if hdr.type != MessageType.DATA:
            raise ProtocolError("unexpected_type", f"participant '{self.name}' got {hdr.type.name} from '{self.partner}' while waiting for {what}")
        d = decode_data(payload)
        if (d.window, d.iteration) != (window, iteration):
            raise ProtocolError("bad_payload", f"participant '{self.name}' and '{self.partner}' are out of step: it sent "
                                f"window {d.window + 1}, pass {d.iteration + 1} while {what} was due")
        reads = [f for f in self.fields if not f.write]
        if len(d.fields) != len(reads):
            raise ProtocolError("bad_payload", f"participant '{self.name}': DATA from '{self.partner}' carries {len(d.fields)} field blocks, {len(reads)} agreed")
        for f, b in zip(reads, d.fields, strict=True):
            if b.field != f.index or b.components != f.comps or b.values.size != f.wire.size:
                raise ProtocolError("bad_payload", f"participant '{self.name}': DATA from '{self.partner}' does not carry field '{f.spec.name}' as agreed")
            if not np.all(np.isfinite(b.values)):
                raise DivergenceError(f"'{self.partner}' sent non-finite values of '{f.spec.name}' in {what}: the partner's solution has blown up")
            f.wire = b.values.reshape(f.wire.shape)
            f.own = f.wire.copy() if f.perm_read is None else f.wire[f.perm_read]
        self.exchanges += 1
        return d.flags, d.residual

    # ------------------------------------------------------------------ schemes
    def _scheme_initialize(self) -> None:
        st = self.state
        if not self.first and st.ongoing:
            self._receive(0, 0)
            self._prev_received = self._received()
            self._last_sent = self._written()
            self._prev_converged = self._last_sent.copy()  # x_(-1) of the linear predictor
            self.acc.start_window()

    def _end_window(self) -> None:
        st, c = self.state, self.config
        w, k = st.window, st.iteration
        last_window = w + 1 >= c.max_windows
        st.total_iterations += 1
        if c.scheme == "explicit":
            if self.first:
                self._send(w, 0, FLAG_LAST_WINDOW if last_window else 0, math.nan)
                self._receive(w, 0)
            else:
                self._send(w, 0, FLAG_CONVERGED | (FLAG_LAST_WINDOW if last_window else 0), math.nan)
            st.window, st.iteration, st.ongoing, st.window_complete = w + 1, 0, not last_window, True
            if not self.first and st.ongoing:
                self._receive(st.window, 0)
            return
        if self.first:
            self._send(w, k, 0, math.nan)
            flags, st.residual = self._receive(w, k)
            complete = bool(flags & FLAG_CONVERGED)
        else:
            xt = self._written()
            if not np.all(np.isfinite(xt)):
                raise DivergenceError(f"non-finite interface values written in window {w + 1}, pass {k + 1}")
            d = self._received()
            res_w = convergence_measure(xt, self._last_sent, self._slices(True), c.tolerance)
            res_r = convergence_measure(d, self._prev_received, self._slices(False), c.tolerance) if k >= 1 else math.inf
            # pass 0 with the linear predictor: the fixed-point residual alone decides (as in C++)
            linear = c.predictor == "linear"
            st.residual = res_w if (k == 0 and linear) else max(res_w, res_r)
            converged = self.test_convergence and (k >= 1 or linear) and st.residual < c.tolerance
            complete = converged or k + 1 >= self.max_passes
            if complete:
                if self.test_convergence and not converged:
                    st.unconverged_windows += 1
                self._send(w, k, FLAG_CONVERGED | (FLAG_LAST_WINDOW if last_window else 0), st.residual)
                if linear:  # the next window starts from 2 x_w - x_(w-1), x_w the value the first participant
                    # applied in this window's last pass (as in C++: not the answer xt, whose accepted errors
                    # the added-mass feedback would multiply); the first participant starts there too
                    applied = self._last_sent.copy()
                    self._last_sent = 2.0 * applied - self._prev_converged
                    self._prev_converged = applied
                else:
                    self._last_sent = xt
            else:
                nxt = self.acc.next(self._last_sent, xt)
                self._set_written(nxt)
                self._send(w, k, 0, st.residual)
                self._last_sent = nxt
        st.window_complete = complete
        if complete:
            st.window, st.iteration, st.ongoing = w + 1, 0, not last_window
            st.write_checkpoint, st.read_checkpoint = st.ongoing, False
            if not self.first:
                self.acc.start_window()
                if st.ongoing:
                    self._receive(st.window, 0)
                    self._prev_received = self._received()
        else:
            st.iteration, st.read_checkpoint = k + 1, True
            if not self.first:
                self._prev_received = self._received()
                self._receive(w, k + 1)

    def _guarded(self, what: str, fn):
        try:
            return fn()
        except PartnerLostError:
            if self.link is not None:
                self.link.close()
            self.finalized = True
            raise
        except CouplerError as e:
            self.abort(f"{what}: {e}")
            raise

    # ------------------------------------------------------------------ time
    def advance(self, dt: float) -> float:
        if not self.is_coupling_ongoing():
            raise ConfigError(f"participant '{self.name}': advance after the coupling has ended (or before initialize)")
        remaining = self.config.window_size - self.time_in_window
        if not dt > 0 or dt > remaining * (1 + 1e-9) + 1e-15:
            raise ConfigError(f"participant '{self.name}': advance({dt} s) but {remaining} s are left in the coupling window")
        self.time_in_window += dt
        st = self.state
        if self.time_in_window < self.config.window_size * (1 - 1e-9):
            st.window_complete = st.write_checkpoint = st.read_checkpoint = False
            return self.get_max_time_step_size()
        self.time_in_window = 0.0
        st.write_checkpoint = False
        self._guarded("advance", self._end_window)
        return self.get_max_time_step_size()

    def is_coupling_ongoing(self) -> bool:
        return self.initialized and not self.finalized and self.state.ongoing

    def is_time_window_complete(self) -> bool:
        return self.state.window_complete

    def requires_writing_checkpoint(self) -> bool:
        return self.initialized and self.state.write_checkpoint

    def requires_reading_checkpoint(self) -> bool:
        return self.initialized and self.state.read_checkpoint

    def get_max_time_step_size(self) -> float:
        return self.config.window_size - self.time_in_window

    # ------------------------------------------------------------------ end
    def finalize(self) -> None:
        if self.finalized:
            return
        if not self.initialized or self.link is None or not self.link.open:
            self.finalized = True
            return
        if self.state.ongoing:
            self.abort(f"participant '{self.name}' finalized before the end of the coupling, in window {self.state.window + 1}")
            return

        def bye():
            self.link.send(MessageType.BYE, encode_reason(Reason(ReasonCode.SOLVER_ERROR, "")),
                           Deadline(self.receive_timeout), "end of coupling")
            hdr, _ = self.link.receive(Deadline(self.receive_timeout), "BYE (end of coupling)")
            if hdr.type != MessageType.BYE:
                raise ProtocolError("unexpected_type", f"participant '{self.name}' expected BYE, got {hdr.type.name}")

        self._guarded("finalize", bye)
        self.link.close()
        self.finalized = True

    def abort(self, reason: str) -> None:
        """Tells the partner this side stops on an error (best effort) and closes."""
        if self.link is not None and self.link.open:
            try:
                self.link.send(MessageType.ABORT, encode_reason(Reason(ReasonCode.SOLVER_ERROR, reason)),
                               Deadline(min(2.0, self.receive_timeout)), "abort")
            except CouplerError:
                pass
            self.link.close()
        self.finalized = True

    def stats(self) -> dict:
        return {
            "exchanges": self.exchanges,
            "seconds_in_transport": self.link.seconds if self.link else 0.0,
            "bytes_sent": self.link.bytes_sent if self.link else 0,
            "bytes_received": self.link.bytes_received if self.link else 0,
            "wall_time": time.perf_counter(),
        }
