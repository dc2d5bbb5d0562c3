"""Byte transports of the coupler (TCP, MPI through mpi4py) and the framed, validated message
endpoint on top of them: the Python twin of coupler/src/transport_tcp.cpp, transport_mpi.cpp and
endpoint.cpp. Same address file, same framing, same checks, same error types."""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

from .protocol import (
    HEADER_SIZE,
    MAX_HANDSHAKE_PAYLOAD,
    MAX_STRING,
    CouplingTimeoutError,
    MessageType,
    PartnerLostError,
    ProtocolError,
    TransportError,
    crc32,
    decode_header,
    decode_reason,
    encode_header,
)


class Deadline:
    def __init__(self, seconds: float):
        self.seconds = seconds
        self.at = time.monotonic() + seconds

    def remaining(self) -> float:
        return self.at - time.monotonic()


# ----------------------------------------------------------------------------- channels
class Channel:
    """An ordered, reliable byte stream to the partner (abstract)."""

    def send(self, data: bytes, deadline: Deadline) -> None:
        raise NotImplementedError

    def receive(self, n: int, deadline: Deadline) -> bytes:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def describe(self) -> str:
        return "?"


class TcpChannel(Channel):
    def __init__(self, sock: socket.socket, desc: str):
        self.sock = sock
        self.desc = desc
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def send(self, data: bytes, deadline: Deadline) -> None:
        view = memoryview(data)
        done = 0
        while done < len(view):
            rem = deadline.remaining()
            if rem <= 0:
                raise CouplingTimeoutError(
                    f"send stalled: the partner did not take the data ({done} of {len(view)} bytes sent) "
                    "before the timeout"
                )
            self.sock.settimeout(rem)
            try:
                done += self.sock.send(view[done:])
            except TimeoutError:
                continue
            except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError) as e:
                raise PartnerLostError(f"connection closed by the partner ({e.strerror}) while sending") from None
            except OSError as e:
                raise TransportError(f"send failed: {e}") from None

    def receive(self, n: int, deadline: Deadline) -> bytes:
        buf = bytearray(n)
        view = memoryview(buf)
        done = 0
        while done < n:
            rem = deadline.remaining()
            if rem <= 0:
                raise CouplingTimeoutError(f"nothing arrived ({done} of {n} expected bytes received)")
            self.sock.settimeout(rem)
            try:
                k = self.sock.recv_into(view[done:])
            except TimeoutError:
                continue
            except (ConnectionResetError, ConnectionAbortedError) as e:
                raise PartnerLostError(f"connection reset by the partner ({e.strerror})") from None
            except OSError as e:
                raise TransportError(f"receive failed: {e}") from None
            if k == 0:
                raise PartnerLostError(
                    f"the partner closed the connection (end of stream) after {done} of {n} expected bytes"
                )
            done += k
        return bytes(buf)

    def close(self) -> None:
        try:
            self.sock.close()
        except OSError:
            pass

    def describe(self) -> str:
        return self.desc


def address_line(host: str, port: int) -> str:
    return f"tqcp 1 tcp {host} {port}\n"


def parse_address_line(line: str) -> tuple[str, int] | None:
    if not line.endswith("\n"):
        return None
    parts = line.split()
    if len(parts) != 5 or parts[:3] != ["tqcp", "1", "tcp"]:
        return None
    try:
        port = int(parts[4])
    except ValueError:
        return None
    return (parts[3], port) if 0 < port < 65536 else None


class TcpListener:
    """Binds `bind` (loopback by default) on port 0 unless told otherwise, and publishes the
    address in `address_file` atomically; removes the file when closed."""

    can_accept_again = True

    def __init__(self, me: str, partner: str, bind: str = "127.0.0.1", port: int = 0, address_file=None):
        self.me, self.partner = me, partner
        infos = socket.getaddrinfo(bind, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
        last = None
        self.sock = None
        for family, stype, proto, _, addr in infos:
            try:
                s = socket.socket(family, stype, proto)
                s.bind(addr)
                s.listen(8)
                self.sock = s
                break
            except OSError as e:
                last = e
        if self.sock is None:
            raise TransportError(f"participant '{me}' cannot listen on {bind}:{port}: {last}")
        self.host = bind
        self.port = self.sock.getsockname()[1]
        self.file = None
        if address_file:
            tmp = f"{address_file}.tmp.{os.getpid()}"
            Path(tmp).write_text(address_line(self.host, self.port))
            os.replace(tmp, address_file)
            self.file = str(address_file)

    def accept(self, deadline: Deadline) -> Channel:
        while True:
            rem = deadline.remaining()
            if rem <= 0:
                raise CouplingTimeoutError(
                    f"participant '{self.me}' listened on {self.describe()} but '{self.partner}' did not connect in time"
                )
            self.sock.settimeout(rem)
            try:
                c, peer = self.sock.accept()
            except TimeoutError:
                continue
            c.setblocking(True)
            return TcpChannel(c, f"tcp {self.host}:{self.port} <- {peer[0]}:{peer[1]}")

    def describe(self) -> str:
        return f"tcp {self.host}:{self.port}" + (f" (address file {self.file})" if self.file else "")

    def close(self) -> None:
        try:
            self.sock.close()
        finally:
            if self.file:
                try:
                    os.remove(self.file)
                except FileNotFoundError:
                    pass
                self.file = None


def connect_tcp(me: str, partner: str, deadline: Deadline, address_file=None, host="127.0.0.1", port=0) -> Channel:
    """Waits for the partner's address file (unless a port is given), then connects, retrying
    while the listener is not up yet."""
    problem = ""
    while True:
        h, p = host, port
        if port <= 0:
            if not address_file:
                raise TransportError(f"participant '{me}' must connect to '{partner}' but has neither an address file nor a port")
            try:
                parsed = parse_address_line(Path(address_file).read_text())
            except FileNotFoundError:
                parsed = None
                problem = f"address file '{address_file}' of '{partner}' does not exist"
            else:
                if parsed is None:
                    problem = f"address file '{address_file}' of '{partner}' is not complete or not valid"
            if parsed is None:
                if deadline.remaining() <= 0:
                    break
                time.sleep(0.02)
                continue
            h, p = parsed
        try:
            s = socket.create_connection((h, p), timeout=max(0.05, min(1.0, deadline.remaining())))
            s.setblocking(True)
            return TcpChannel(s, f"tcp -> {h}:{p}")
        except OSError as e:
            problem = f"connection to {h}:{p} failed: {e.strerror or e}"
        if deadline.remaining() <= 0:
            break
        time.sleep(0.02)
    raise CouplingTimeoutError(f"participant '{me}' could not reach '{partner}' before the connect timeout: {problem}")


# ----------------------------------------------------------------------------- MPI
MPI_TAG = 0x7C01


def colour_of(name: str) -> int:
    """FNV-1a (32 bit) of the UTF-8 name, as the C++ splitWorld."""
    h = 2166136261
    for c in name.encode("utf-8"):
        h ^= c
        h = (h * 16777619) & 0xFFFFFFFF
    return h & 0x7FFFFFFF


class MpiWorld:
    """MPMD start-up under mpirun (a collective over COMM_WORLD, as the C++ mpi::splitWorld):
    splits the world by application and finds the partner's leader."""

    def __init__(self, me: str, partner: str):
        import numpy as np
        from mpi4py import MPI

        self.MPI = MPI
        world = MPI.COMM_WORLD
        # Buffer-based collectives in the same order as the C++ splitWorld (Allgather of one
        # int, Comm_split, Comm_dup): the two applications take part in the same collectives.
        mine = np.array([colour_of(me)], dtype=np.int32)
        colours = np.zeros(world.Get_size(), dtype=np.int32)
        world.Allgather([mine, MPI.INT], [colours, MPI.INT])
        self.app = world.Split(colour_of(me), world.Get_rank())
        self.link = world.Dup()
        self.world_rank = world.Get_rank()
        theirs = colour_of(partner)
        leaders = [r for r, c in enumerate(colours.tolist()) if c == theirs]
        if not leaders:
            raise TransportError(
                f"participant '{me}': no process of '{partner}' among the {world.Get_size()} MPI processes: "
                "start both under one mpirun (MPMD)"
            )
        self.partner_leader = leaders[0]


class MpiChannel(Channel):
    can_accept_again = False

    def __init__(self, world: MpiWorld):
        self.w = world
        self.buf = b""

    def send(self, data: bytes, deadline: Deadline) -> None:
        req = self.w.link.Isend([data, self.w.MPI.BYTE], dest=self.w.partner_leader, tag=MPI_TAG)
        spins = 0
        while not req.Test():
            if deadline.remaining() <= 0:
                raise CouplingTimeoutError("send stalled: the partner did not take the data before the timeout")
            spins += 1
            if spins > 2000:
                time.sleep(2e-4)

    def receive(self, n: int, deadline: Deadline) -> bytes:
        out = bytearray()
        while len(out) < n:
            if self.buf:
                k = min(n - len(out), len(self.buf))
                out += self.buf[:k]
                self.buf = self.buf[k:]
                continue
            st = self.w.MPI.Status()
            spins = 0
            while not self.w.link.Iprobe(source=self.w.partner_leader, tag=MPI_TAG, status=st):
                if deadline.remaining() <= 0:
                    raise CouplingTimeoutError(f"nothing arrived ({len(out)} of {n} expected bytes received)")
                spins += 1
                if spins > 2000:
                    time.sleep(2e-4)
            count = st.Get_count(self.w.MPI.BYTE)
            b = bytearray(count)
            self.w.link.Recv([b, self.w.MPI.BYTE], source=self.w.partner_leader, tag=MPI_TAG)
            self.buf = bytes(b)
        return bytes(out)

    def describe(self) -> str:
        return f"mpi world rank {self.w.world_rank} <-> world rank {self.w.partner_leader}"


class MpiListener:
    can_accept_again = False

    def __init__(self, world: MpiWorld):
        self.world = world

    def accept(self, deadline: Deadline) -> Channel:
        return MpiChannel(self.world)

    def describe(self) -> str:
        return f"mpi leader of the partner (world rank {self.world.partner_leader})"

    def close(self) -> None:
        pass


# ----------------------------------------------------------------------------- endpoint
def _limit_for(t: MessageType, expected_data: int) -> int:
    if t in (MessageType.HELLO, MessageType.WELCOME):
        return MAX_HANDSHAKE_PAYLOAD
    if t == MessageType.READY:
        return 0
    if t in (MessageType.REJECT, MessageType.ABORT, MessageType.BYE):
        return 8 + MAX_STRING
    return expected_data or MAX_HANDSHAKE_PAYLOAD


class Endpoint:
    """Framed, validated messages over a Channel (the C++ Endpoint)."""

    def __init__(self, channel: Channel, me: str, partner: str):
        self.channel = channel
        self.me, self.partner = me, partner
        self.send_seq = 0
        self.recv_seq = 0
        self.expected_data = 0
        self.seconds = 0.0
        self.bytes_sent = 0
        self.bytes_received = 0

    @property
    def open(self) -> bool:
        return self.channel is not None

    def close(self) -> None:
        if self.channel is not None:
            self.channel.close()
        self.channel = None

    def send(self, mtype: MessageType, payload: bytes, deadline: Deadline, context: str) -> None:
        if self.channel is None:
            raise TransportError(f"participant '{self.me}' cannot send {mtype.name} ({context}): the link to '{self.partner}' is closed")
        msg = encode_header(mtype, self.send_seq, payload) + payload
        t0 = time.perf_counter()
        try:
            self.channel.send(msg, deadline)
        except TransportError as e:
            raise type(e)(
                f"participant '{self.me}' sending {mtype.name} ({context}) to '{self.partner}' over {self.channel.describe()}: {e}"
            ) from None
        finally:
            self.seconds += time.perf_counter() - t0
        self.bytes_sent += len(msg)
        self.send_seq += 1

    def receive(self, deadline: Deadline, expecting: str):
        """Returns (header, payload) after checking header, sequence, length limit and payload
        CRC; ABORT from the partner becomes PartnerLostError with the partner's reason."""
        who = f"participant '{self.me}' waiting for {expecting} from '{self.partner}'"
        if self.channel is None:
            raise TransportError(f"{who}: the link is closed")
        t0 = time.perf_counter()
        try:
            h = decode_header(self.channel.receive(HEADER_SIZE, deadline))
            if h.sequence != self.recv_seq:
                raise ProtocolError(
                    "bad_sequence",
                    f"sequence number {h.sequence} where {self.recv_seq} was due (a message was lost, repeated or reordered)",
                )
            limit = _limit_for(h.type, self.expected_data)
            exact = h.type == MessageType.DATA and self.expected_data
            if (h.payload_length != limit) if exact else (h.payload_length > limit):
                raise ProtocolError(
                    "bad_length",
                    f"{h.type.name} announces {h.payload_length} payload bytes; "
                    + (f"the handshake fixed exactly {limit} (interface sizes differ?)" if exact else f"the limit is {limit}"),
                )
            payload = self.channel.receive(h.payload_length, deadline) if h.payload_length else b""
            if crc32(payload) != h.payload_crc:
                raise ProtocolError("bad_payload_crc", f"{h.type.name} payload corrupted (payload CRC-32 mismatch)")
        except CouplingTimeoutError as e:
            raise CouplingTimeoutError(
                f"{who}: {e} within the timeout of {deadline.seconds:g} s. The partner is hung or slower than "
                "the timeout allows (raise coupling.timeout if it is only slow)."
            ) from None
        except PartnerLostError as e:
            raise PartnerLostError(f"{who}: {e}. The partner process has probably stopped: see its log.") from None
        except ProtocolError as e:
            raise ProtocolError(e.fault, f"{who} over {self.channel.describe()}: refused a message: {e}") from None
        except TransportError as e:
            raise TransportError(f"{who}: {e}") from None
        finally:
            self.seconds += time.perf_counter() - t0
        self.bytes_received += HEADER_SIZE + len(payload)
        self.recv_seq += 1
        if h.type == MessageType.ABORT:
            r = decode_reason(payload)
            raise PartnerLostError(f"'{self.partner}' stopped on an error while '{self.me}' was waiting for {expecting}: {r.message}")
        return h, payload
