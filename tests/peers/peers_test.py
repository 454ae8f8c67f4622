#!/usr/bin/env python3
"""ferrule's Modbus client and servers against real peers: libmodbus, pymodbus and mbpoll.

usage: peers_test.py <ferrule_peer> <libmodbus_peer> <pymodbus_peer.py>

RTU runs over a socat pty pair (19200 8N1: ptys carry no parity), TCP on 127.0.0.1. Every
pairing gets a fresh server serving the peer map (libmodbus_peer.c), so each client's writes
start from the same tables. The clients' own 'ok' / 'FAIL' lines are passed through with the
pairing's name; the last line is 'N passed, M failed' over all of them.
"""
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import prereq  # noqa: E402

ferrule_peer, libmodbus_peer, pymodbus_peer = sys.argv[1:4]
pymodbus = [prereq.SYSTEM_PYTHON, pymodbus_peer]  # Debian's python3-pymodbus
passed = failed = 0

# Every peer program and module first: a missing one is one line naming its package.
missing = prereq.missing(programs=["socat", "mbpoll"],
                         modules=["pymodbus", "serial", "serial_asyncio"])
for line in missing:
    print(f"FAIL prerequisite: {line}")
if missing:
    print(f"0 passed, {len(missing)} failed")
    sys.exit(1)


def record(pairing, line):
    global passed, failed
    if line.startswith("ok "):
        passed += 1
        print(f"ok {pairing}: {line[3:]}")
    elif line.startswith("FAIL "):
        failed += 1
        print(f"FAIL {pairing}: {line[5:]}")


def fail(pairing, why):
    global failed
    failed += 1
    print(f"FAIL {pairing}: {why}")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Pty:
    """A socat pty pair: the server opens `a`, the client `b`."""

    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="ferrule-peers-")
        self.a, self.b = os.path.join(self.dir, "a"), os.path.join(self.dir, "b")
        self.proc = subprocess.Popen(["socat", f"pty,raw,echo=0,link={self.a}",
                                      f"pty,raw,echo=0,link={self.b}"], stderr=subprocess.DEVNULL)
        for _ in range(100):
            if os.path.exists(self.a) and os.path.exists(self.b):
                return
            time.sleep(0.02)
        raise RuntimeError("socat did not make its ptys")

    def close(self):
        self.proc.terminate()
        self.proc.wait(timeout=10)
        shutil.rmtree(self.dir, ignore_errors=True)


def server(cmd):
    """Starts a server that prints 'ready' when it listens."""
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.stdout.readline().strip() != "ready":
        p.kill()
        raise RuntimeError(f"{cmd[0]} did not start: {p.stderr.read()}")
    return p


def stop(srv):
    """Ends a server (libmodbus's blocks in select() through SIGTERM: SIGKILL)."""
    srv.kill()
    srv.wait(timeout=10)


def client(pairing, cmd, expect_min):
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=120).stdout
    except subprocess.TimeoutExpired:
        return fail(pairing, "the client did not finish in 120 s")
    before = passed
    for line in out.splitlines():
        record(pairing, line)
    if passed - before < expect_min:
        fail(pairing, f"only {passed - before} checks passed, expected at least {expect_min}:\n{out}")


def rtu(pairing, server_cmd, client_cmd, expect_min):
    line = Pty()
    srv = None
    try:
        srv = server([a.replace("{tty}", line.a) for a in server_cmd])
        client(pairing, [a.replace("{tty}", line.b) for a in client_cmd], expect_min)
    except RuntimeError as e:
        fail(pairing, str(e))
    finally:
        if srv:
            stop(srv)
        line.close()


def wait_listening(port):
    """pymodbus says 'ready' before its server has bound the port: wait until it accepts."""
    for _ in range(250):
        try:
            socket.create_connection(("127.0.0.1", int(port)), timeout=1).close()
            return
        except OSError:
            time.sleep(0.02)
    raise RuntimeError(f"nothing listens on port {port}")


def tcp(pairing, server_cmd, client_cmd, expect_min):
    port = str(free_port())
    srv = None
    try:
        srv = server([a.replace("{port}", port) for a in server_cmd])
        wait_listening(port)
        client(pairing, [a.replace("{port}", port) for a in client_cmd], expect_min)
    except RuntimeError as e:
        fail(pairing, str(e))
    finally:
        if srv:
            stop(srv)


# RTU over a pty pair.
rtu("ferrule RTU client -> libmodbus RTU server",
    [libmodbus_peer, "rtu-server", "{tty}", "1"], [ferrule_peer, "rtu-client", "{tty}", "1"], 11)
rtu("libmodbus RTU client -> ferrule RTU server",
    [ferrule_peer, "rtu-server", "{tty}", "1"], [libmodbus_peer, "rtu-client", "{tty}", "1", "--ferrule-extras"], 15)
rtu("pymodbus RTU client -> ferrule RTU server",
    [ferrule_peer, "rtu-server", "{tty}", "1"], [*pymodbus, "rtu-client", "{tty}", "1", "--ferrule-extras"], 14)

# TCP on loopback.
tcp("ferrule TCP client -> pymodbus TCP server",
    [*pymodbus, "tcp-server", "{port}"], [ferrule_peer, "tcp-client", "{port}", "1", "--extras"], 12)
tcp("ferrule TCP client -> libmodbus TCP server",
    [libmodbus_peer, "tcp-server", "{port}"], [ferrule_peer, "tcp-client", "{port}", "1"], 10)
tcp("libmodbus TCP client -> ferrule TCP server",
    [ferrule_peer, "tcp-server", "{port}"], [libmodbus_peer, "tcp-client", "{port}", "1", "--ferrule-extras"], 14)
tcp("pymodbus TCP client -> ferrule TCP server",
    [ferrule_peer, "tcp-server", "{port}"], [*pymodbus, "tcp-client", "{port}", "1", "--ferrule-extras"], 13)
# Stray bytes that start no request: ferrule closes the connection, libmodbus reconnects.
tcp("libmodbus TCP client, eight stray zero bytes -> ferrule TCP server",
    [ferrule_peer, "tcp-server", "{port}"], [libmodbus_peer, "tcp-client-stray-zeros", "{port}", "1"], 4)

# mbpoll against ferrule's TCP server: reads of each table, writes, and an exception.
port = str(free_port())
srv = server([ferrule_peer, "tcp-server", port])
try:
    def mbpoll(*args, write=()):
        # mbpoll [options] host [values to write]
        return subprocess.run(["mbpoll", "-m", "tcp", "-p", port, "-a", "1", "-1", *args, "127.0.0.1", *write],
                              capture_output=True, text=True, timeout=30)

    def values(out):
        return [line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("[")]

    pairing = "mbpoll -> ferrule TCP server"
    r = mbpoll("-t", "4", "-r", "1", "-c", "3")  # mbpoll counts references from 1
    record(pairing, "ok FC3 holding registers 0-2" if values(r.stdout) == ["4096", "4097", "4098"]
           else f"FAIL FC3 holding registers 0-2: {r.stdout}{r.stderr}")
    r = mbpoll("-t", "3", "-r", "91", "-c", "2")
    record(pairing, "ok FC4 input registers 90-91" if values(r.stdout) == ["8282", "8283"]
           else f"FAIL FC4 input registers 90-91: {r.stdout}{r.stderr}")
    r = mbpoll("-t", "0", "-r", "1", "-c", "4")
    record(pairing, "ok FC1 coils 0-3" if values(r.stdout) == ["1", "0", "0", "1"]
           else f"FAIL FC1 coils 0-3: {r.stdout}{r.stderr}")
    r = mbpoll("-t", "1", "-r", "1", "-c", "2")
    record(pairing, "ok FC2 discrete inputs 0-1" if values(r.stdout) == ["0", "1"]
           else f"FAIL FC2 discrete inputs 0-1: {r.stdout}{r.stderr}")
    w = mbpoll("-t", "4", "-r", "61", write=("4660", "22136"))
    r = mbpoll("-t", "4", "-r", "61", "-c", "2")
    record(pairing, "ok FC16 write registers 60-61, read back" if w.returncode == 0 and values(r.stdout) == ["4660", "22136"]
           else f"FAIL FC16 write registers 60-61: {w.stdout}{w.stderr}{r.stdout}")
    w = mbpoll("-t", "0", "-r", "71", write=("1",))
    r = mbpoll("-t", "0", "-r", "71", "-c", "1")
    record(pairing, "ok FC5 write coil 70, read back" if w.returncode == 0 and values(r.stdout) == ["1"]
           else f"FAIL FC5 write coil 70: {w.stdout}{w.stderr}{r.stdout}")
    r = mbpoll("-t", "4", "-r", "101", "-c", "1")
    record(pairing, "ok exception 02 reported" if "Illegal data address" in r.stdout + r.stderr
           else f"FAIL exception 02: {r.stdout}{r.stderr}")
finally:
    stop(srv)

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
