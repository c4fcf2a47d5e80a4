#!/usr/bin/env python3
"""The console's Foxglove live port (ajar-console --foxglove) under hostile connections:

  idle      N connections that connect and never send their HTTP request (no upgrade), held open
  trickle   N connections that send the request one byte per second, never finishing
  garbage   connections that send random bytes / a huge header / an HTTP request with a body
  many      N full WebSocket upgrades (foxglove.websocket.v1) that never read

After each: does a well-behaved Foxglove client still upgrade and get the serverInfo/advertise
within 5 s; does the console's page (http GET /) still answer; does the console keep its link to
ajard (a controller-less observer sees Telemetry); and the console process' open files.

Usage: foxglove_attack.py [idle|trickle|garbage|many|all] [N]
"""
import base64
import os
import random
import socket
import subprocess
import sys
import time

from ajarwire import *

what = sys.argv[1] if len(sys.argv) > 1 else "all"
N = int(sys.argv[2]) if len(sys.argv) > 2 else 300
CONSOLE = os.environ.get("AJAR_CONSOLE", os.path.join(BUILD, "console", "ajar-console"))
fails = []


def start_console(port):
    p = subprocess.Popen([CONSOLE, "--connect", "127.0.0.1:%d" % port, "--listen", "127.0.0.1:0",
                          "--foxglove", "127.0.0.1:0", "--observer"],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    page = fox = None
    end = time.monotonic() + 20
    while time.monotonic() < end and (page is None or fox is None):
        line = p.stdout.readline()
        if not line:
            break
        if "open http://" in line:
            page = int(line.split("http://")[1].split("/")[0].rsplit(":", 1)[1])
        if "Foxglove live at ws://" in line:
            fox = int(line.split("ws://")[1].split("/")[0].rsplit(":", 1)[1])
    return p, page, fox


def upgrade(port, timeout=5.0):
    """A well-behaved Foxglove client: upgrade, read the first message. True when it got one."""
    try:
        s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        s.sendall(("GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\n"
                   "Connection: Upgrade\r\nSec-WebSocket-Key: %s\r\nSec-WebSocket-Version: 13\r\n"
                   "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n" % (port, key)).encode())
        buf = b""
        end = time.monotonic() + timeout
        while b"\r\n\r\n" not in buf and time.monotonic() < end:
            buf += s.recv(4096)
        if b" 101 " not in buf.split(b"\r\n")[0]:
            return False, buf.split(b"\r\n")[0]
        rest = buf.split(b"\r\n\r\n", 1)[1]
        while len(rest) < 2 and time.monotonic() < end:
            rest += s.recv(4096)
        s.close()
        return len(rest) >= 2, "first frame opcode %#x" % (rest[0] & 0x0F) if rest else "none"
    except OSError as e:
        return False, str(e)


def page_ok(port):
    try:
        s = socket.create_connection(("127.0.0.1", port), timeout=5)
        s.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\n\r\n" % port)
        r = s.recv(100)
        s.close()
        return r.startswith(b"HTTP/1.1 200")
    except OSError as e:
        return False


def nfds(pid):
    try:
        return len(os.listdir("/proc/%d/fd" % pid))
    except OSError:
        return -1


def check(name, p, page, fox, obs):
    good, detail = upgrade(fox)
    pg = page_ok(page)
    n0 = len(obs.telems())
    obs.poll(0.5)
    alive = p.poll() is None
    line = "%-8s Foxglove client upgrades: %s (%s); page answers: %s; console alive: %s; " \
           "console fds: %d" % (name, good, detail, pg, alive, nfds(p.pid))
    if good and pg and alive:
        say("  OK " + line)
    else:
        say("  FAIL " + line)
        fails.append(line)


d = Daemon({"drivers.kind": "sim"}, name="foxglove")
p = None
held = []
try:
    d.start()
    obs = d.conn(1)
    obs.call(SUBSCRIBE, struct.pack("<f", 20.0))
    p, page, fox = start_console(d.port)
    assert fox, "the console did not print its Foxglove port"
    say("console page :%d, Foxglove :%d, fds %d" % (page, fox, nfds(p.pid)))
    check("start", p, page, fox, obs)
    if what in ("idle", "all"):
        for _ in range(N):
            try:
                held.append(socket.create_connection(("127.0.0.1", fox), timeout=2))
            except OSError as e:
                say("  connect %d failed: %s" % (len(held), e))
                break
        time.sleep(1)
        check("idle x%d" % len(held), p, page, fox, obs)
        time.sleep(10)
        check("idle+10s", p, page, fox, obs)
        for s in held:
            s.close()
        held = []
    if what in ("trickle", "all"):
        req = b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n" % fox
        for _ in range(min(N, 100)):
            s = socket.create_connection(("127.0.0.1", fox), timeout=2)
            held.append(s)
        for i in range(5):
            for s in held:
                try:
                    s.send(req[i:i + 1])
                except OSError:
                    pass
            time.sleep(1)
        check("trickle", p, page, fox, obs)
        for s in held:
            s.close()
        held = []
    if what in ("garbage", "all"):
        rng = random.Random(1)
        blobs = [bytes(rng.randrange(256) for _ in range(4000)), b"\r\n" * 5000,
                 b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nX: %s\r\n\r\n" % (fox, b"a" * 100000),
                 b"POST / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nContent-Length: 100000000\r\n\r\n" %
                 fox + b"x" * 65536,
                 b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\nConnection: "
                 b"Upgrade\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: x\r\n"
                 b"Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n" % fox + os.urandom(5000)]
        for b in blobs * 20:
            try:
                s = socket.create_connection(("127.0.0.1", fox), timeout=2)
                s.sendall(b)
                s.close()
            except OSError:
                pass
        check("garbage", p, page, fox, obs)
    if what in ("many", "all"):
        socks = []
        for i in range(N):
            try:
                s = socket.create_connection(("127.0.0.1", fox), timeout=2)
                key = base64.b64encode(os.urandom(16)).decode()
                s.sendall(("GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\n"
                           "Connection: Upgrade\r\nSec-WebSocket-Key: %s\r\n"
                           "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: "
                           "foxglove.websocket.v1\r\n\r\n" % (fox, key)).encode())
                socks.append(s)
            except OSError as e:
                say("  connect %d failed: %s" % (i, e))
                break
        time.sleep(2)
        upgraded = 0
        for s in socks:
            try:
                s.settimeout(0.2)
                upgraded += b" 101 " in s.recv(200)
            except OSError:
                pass
        say("  %d of %d upgraded (the rest refused: max clients)" % (upgraded, len(socks)))
        check("many x%d" % len(socks), p, page, fox, obs)
        time.sleep(5)
        check("many+5s", p, page, fox, obs)
        for s in socks:
            s.close()
    time.sleep(1)
    check("end", p, page, fox, obs)
finally:
    for s in held:
        s.close()
    if p and p.poll() is None:
        p.terminate()
        p.wait(10)
    d.stop()
say("%d failures" % len(fails))
for f in fails:
    say("  " + f)
sys.exit(1 if fails else 0)
