#!/usr/bin/env python3
"""The limits of ferrule-sim's TCP servers (Modbus TCP, Extended MEMOBUS) against clients that
would hold them: slow-drip clients on every connection or channel, an idle client, bad MBAP
headers; each limit's count in the exit summary.

usage: server_limits_test.py <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
Nothing sleeps: each wait is a select() for the server's close or reply, with a deadline.
"""
import select
import socket
import subprocess
import sys
import time

from harness import check, summary

ferrule_sim = sys.argv[1]

# An Extended MEMOBUS SFC 09 command, read MW00000 x4 (protocols/memobus.md §8.1), 22 bytes.
MEMOBUS_READ = bytes.fromhex("11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 09 10 00 00 00 04 00")
# A Modbus TCP request: transaction 1, FC 3, register 0xC802 (the VFD's status), 12 bytes.
MODBUS_READ = bytes.fromhex("00 01 00 00 00 06 01 03 C8 02 00 01")


class Server:
    """`ferrule-sim <args…>` up until it prints its TCP address (IP:PORT) on stdout."""

    def __init__(self, *args):
        self.proc = subprocess.Popen([ferrule_sim, *args], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        address = self.proc.stdout.readline().strip()
        if not address.startswith("127.0.0.1:"):
            self.proc.kill()
            raise RuntimeError(f"ferrule-sim {args[0]} did not come up: {address!r} "
                               f"{self.proc.stderr.read()}")
        self.port = int(address.split(":")[1])

    def connect(self):
        return socket.create_connection(("127.0.0.1", self.port), timeout=5)

    def stop(self):
        """Ends the simulator; returns what it printed on stderr."""
        self.proc.terminate()
        self.proc.wait(timeout=10)
        return self.proc.stderr.read()


def closed_within(s, seconds):
    """What the server sent until it closed the connection, or None when it has not closed it
    within `seconds`."""
    got = b""
    deadline = time.monotonic() + seconds
    while True:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([s], [], [], left)[0]:
            return None
        try:
            data = s.recv(512)
        except ConnectionResetError:
            return got
        if not data:
            return got
        got += data


def drip_until_closed(sockets, message, interval, seconds):
    """Sends `message` a byte at a time on every socket, `interval` s apart, until the server
    has closed them all; the number closed within `seconds`. The wait between two bytes is a
    wait for the closes."""
    left = set(sockets)
    deadline = time.monotonic() + seconds
    i = 0
    while left and time.monotonic() < deadline:
        for s in list(left):
            try:
                s.send(message[i % len(message):i % len(message) + 1])
            except OSError:
                left.discard(s)
        i += 1
        ready = select.select(list(left), [], [], interval)[0] if left else []
        for s in ready:
            try:
                if not s.recv(512):
                    left.discard(s)
            except ConnectionResetError:
                left.discard(s)
    return len(sockets) - len(left)


def refused(srv):
    """A connection the server accepts and closes at once, with nothing sent."""
    with srv.connect() as s:
        return closed_within(s, 2) == b""


def read_exactly(s, size, seconds=2):
    """`size` bytes the server sends within `seconds`, or None (also when it closes first)."""
    got = b""
    deadline = time.monotonic() + seconds
    while len(got) < size:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([s], [], [], left)[0]:
            return None
        try:
            data = s.recv(size - len(got))
        except ConnectionResetError:
            return None
        if not data:
            return None
        got += data
    return got


def memobus_answered(srv):
    """A response (type 0x19) with the command's serial, framed by its total length (§2)."""
    with srv.connect() as s:
        s.sendall(MEMOBUS_READ)
        header = read_exactly(s, 12)
        if header is None:
            return False
        body = read_exactly(s, int.from_bytes(header[6:8], "little") - 12)
        return body is not None and header[0] == 0x19 and header[1] == MEMOBUS_READ[1]


def modbus_answered(srv):
    with srv.connect() as s:
        s.sendall(MODBUS_READ)
        reply = read_exactly(s, 11)
        return reply is not None and reply[:2] == MODBUS_READ[:2] and reply[7] == 0x03


def memobus_drip_with_old_flags():
    """Four masters dripping a byte every 0.5 s on every channel of a 218IFA (--channels 4)
    with --idle-timeout 3, flags ferrule-sim has long had: while any byte reset the idle
    timeout they kept a fifth master out for the whole run. The request deadline (2 s by
    default) closes them."""
    srv = Server("memobus", "--port", "0", "--idle-timeout", "3")
    try:
        drippers = [srv.connect() for _ in range(4)]
        check("MEMOBUS: a fifth master beyond the 4 channels is refused", refused(srv))
        closed = drip_until_closed(drippers, MEMOBUS_READ, 0.5, 8)
        check("MEMOBUS: 4 masters dripping a byte every 0.5 s are closed by the request deadline",
              closed == 4, f"{closed} closed")
        check("MEMOBUS: then a fifth master is answered", memobus_answered(srv))
        for s in drippers:
            s.close()
    finally:
        err = srv.stop()
    check("MEMOBUS: the summary counts the refused master and the request timeouts",
          "5 TCP connections (1 refused, 0 idle closed, 4 request timeouts)" in err, err)


def memobus_timeout_flags():
    """--request-timeout and --idle-timeout in fractions of a second."""
    srv = Server("memobus", "--port", "0", "--idle-timeout", "0.5", "--request-timeout", "0.2")
    try:
        with srv.connect() as dripper:
            check("MEMOBUS --request-timeout 0.2: a dripping master is closed",
                  drip_until_closed([dripper], MEMOBUS_READ, 0.1, 3) == 1)
        with srv.connect() as idle:
            idle.sendall(MEMOBUS_READ)
            start = time.monotonic()
            got = closed_within(idle, 3)
            check("MEMOBUS --idle-timeout 0.5: answered, then closed 0.5 s after the request",
                  got is not None and len(got) > 12 and time.monotonic() - start >= 0.4,
                  repr(got))
    finally:
        err = srv.stop()
    check("MEMOBUS: the summary counts the idle close and the request timeout",
          "(0 refused, 1 idle closed, 1 request timeouts)" in err, err)


def modbus_bad_header():
    """Modbus TCP with its defaults: eight zero bytes, then requests. The server closes the
    connection at once, unanswered, and says so; the client is served again on a new one."""
    srv = Server("modbus", "--tcp", "0", "--tcp-only")
    try:
        with srv.connect() as s:
            s.sendall(bytes(8) + MODBUS_READ * 6)
            got = closed_within(s, 1)
            check("Modbus TCP: eight zero bytes close the connection at once, unanswered",
                  got == b"", repr(got))
        check("Modbus TCP: a new connection is answered", modbus_answered(srv))
    finally:
        err = srv.stop()
    check("Modbus TCP: the bad header is logged",
          "an MBAP header that no Modbus request starts with" in err, err)
    check("Modbus TCP: the summary counts the bad header",
          "2 connections (0 refused, 0 idle closed, 0 request timeouts, 1 bad MBAP headers), "
          "1 replies" in err, err)


def modbus_limit_flags():
    """Modbus TCP with --connections, --idle-timeout and --request-timeout."""
    srv = Server("modbus", "--tcp", "0", "--tcp-only", "--connections", "2", "--idle-timeout",
                 "0.5", "--request-timeout", "0.2")
    try:
        drippers = [srv.connect() for _ in range(2)]
        check("Modbus TCP --connections 2: a third client is refused", refused(srv))
        closed = drip_until_closed(drippers, MODBUS_READ, 0.1, 3)
        check("Modbus TCP --request-timeout 0.2: both dripping clients are closed", closed == 2,
              f"{closed} closed")
        for s in drippers:
            s.close()
        with srv.connect() as idle:
            idle.sendall(MODBUS_READ)
            start = time.monotonic()
            got = closed_within(idle, 3)
            check("Modbus TCP --idle-timeout 0.5: answered, then closed 0.5 s after the request",
                  got is not None and len(got) == 11 and time.monotonic() - start >= 0.4,
                  repr(got))
    finally:
        err = srv.stop()
    check("Modbus TCP: the summary counts each limit",
          "(1 refused, 1 idle closed, 2 request timeouts, 0 bad MBAP headers), 1 replies" in err,
          err)


for scenario in (memobus_drip_with_old_flags, memobus_timeout_flags, modbus_bad_header,
                 modbus_limit_flags):
    try:
        scenario()
    except (RuntimeError, OSError) as e:
        check(scenario.__name__, False, f"{type(e).__name__}: {e}")

sys.exit(summary())
