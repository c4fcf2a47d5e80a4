#!/usr/bin/env python3
"""Item 3: TLS handshakes against SIGHUP.

Usage: tls_withhold.py [trials] [seed]
 A) the client withholds its second flight (Certificate, CertificateVerify, Finished) — or only
    part of it — the operator revokes its certificate (new CRL) and sends SIGHUP, then the client
    completes: must be refused (no Welcome as controller, no Drive acked).
 B) SIGHUP storms (0..20 signals, random gaps) while many handshakes are in flight at random
    steps: daemon must survive, keep answering, and refuse the revoked one.
"""
import os
import random
import signal
import socket
import ssl
import struct
import subprocess
import sys
import time

from ajarwire import *

trials = int(sys.argv[1]) if len(sys.argv) > 1 else 6
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)

pki = tempfile.mkdtemp(prefix="ajar-pki-")
mc = os.path.join(ROOT, "scripts", "make-certs")
subprocess.run([mc, "--dir", pki, "ca"], check=True, stdout=subprocess.DEVNULL)
subprocess.run([mc, "--dir", pki, "daemon", "127.0.0.1"], check=True, stdout=subprocess.DEVNULL)
names = ["op%d" % i for i in range(trials + 1)]
for n in names:
    subprocess.run([mc, "--dir", pki, "operator", n, "controller"], check=True,
                   stdout=subprocess.DEVNULL)
use_tls(pki, [(n, "controller") for n in names], ("handshake_timeout_s: 30", "unlisted: refuse"))

d = Daemon({"drivers.kind": "mock"}, name="tls")
d.start()


def ctx_for(name):
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    ctx.minimum_version = ssl.TLSVersion.TLSv1_3
    ctx.load_verify_locations(os.path.join(pki, "ca.crt"))
    ctx.load_cert_chain(os.path.join(pki, name + ".crt"), os.path.join(pki, name + ".key"))
    return ctx


class TlsStepper:
    """Client handshake over a raw socket with memory BIOs: returns the client's flights."""

    def __init__(self, name):
        self.sock = socket.create_connection(("127.0.0.1", d.port), timeout=5)
        self.inc, self.out = ssl.MemoryBIO(), ssl.MemoryBIO()
        self.obj = ctx_for(name).wrap_bio(self.inc, self.out, server_hostname="127.0.0.1")
        self.plain = b""

    def first_flight(self):
        try:
            self.obj.do_handshake()
        except ssl.SSLWantReadError:
            pass
        self.sock.sendall(self.out.read())

    def read_server_flight(self):
        """Read until the client's handshake completes locally; return its second flight."""
        end = time.monotonic() + 5
        while time.monotonic() < end:
            data = self.sock.recv(65536)
            if not data:
                raise ConnectionError("closed during handshake")
            self.inc.write(data)
            try:
                self.obj.do_handshake()
                return self.out.read()
            except ssl.SSLWantReadError:
                continue
        raise TimeoutError

    def send(self, data):
        self.obj.write(data)
        self.sock.sendall(self.out.read())

    def recv_frames(self, timeout=3.0):
        """Decoded frames until timeout or close; returns (frames, closed, alert)."""
        frames, end, alert = [], time.monotonic() + timeout, None
        self.sock.settimeout(0.1)
        while time.monotonic() < end:
            try:
                data = self.sock.recv(65536)
            except socket.timeout:
                data = None
            except OSError as e:
                return frames, True, str(e)
            if data == b"":
                return frames, True, alert
            if data:
                self.inc.write(data)
            while True:
                try:
                    self.plain += self.obj.read(65536)
                except ssl.SSLWantReadError:
                    break
                except ssl.SSLError as e:
                    return frames, True, e.reason
                except ssl.SSLZeroReturnError:
                    return frames, True, "close_notify"
            while len(self.plain) >= 22:
                ln = struct.unpack_from("<I", self.plain, 14)[0]
                if len(self.plain) < 22 + ln:
                    break
                t, rid = struct.unpack_from("<HxxI", self.plain, 6)
                frames.append(Msg(t, rid, self.plain[22:22 + ln]))
                self.plain = self.plain[22 + ln:]
        return frames, False, alert


def revoke(name):
    subprocess.run([mc, "--dir", pki, "revoke", name], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)


fails = []
try:
    # Part A
    for trial in range(trials):
        name = names[trial]
        split = rng.choice(["all", "none", "half", "byte"])
        t = TlsStepper(name)
        t.first_flight()
        second = t.read_server_flight()
        if split == "half":
            t.sock.sendall(second[:len(second) // 2])
            second = second[len(second) // 2:]
        elif split == "byte":
            t.sock.sendall(second[:1])
            second = second[1:]
        elif split == "none":
            pass
        revoke(name)
        nhup = rng.randint(1, 4)
        for _ in range(nhup):
            d.signal(signal.SIGHUP)
            time.sleep(rng.uniform(0, 0.1))
        time.sleep(0.3)
        t.sock.sendall(second)
        hello_f = frame(HELLO, hello(0, True), 1)
        drive_f = frame(DRIVE, drive(0.1, 0.0), 2)
        try:
            t.send(hello_f + drive_f)
        except OSError as e:
            pass
        frames, closed, alert = t.recv_frames(2.0)
        welcomed = [f for f in frames if f.type == WELCOME]
        acked = [f for f in frames if f.type == ACK]
        bad = bool(welcomed) or bool(acked)
        line = "A trial %d (%s, split=%s, %d SIGHUP): frames %s closed=%s alert=%s" % (
            trial, name, split, nhup, frames, closed, alert)
        say(("FAIL " if bad else "ok   ") + line)
        if bad:
            fails.append(line)
        t.sock.close()
        # a fresh connection of the same cert must be refused
    # Part B: storms with handshakes at random steps, a still-valid identity
    good = names[-1]
    wel = 0
    for trial in range(trials * 3):
        ts = []
        for i in range(rng.randint(1, 8)):
            try:
                x = TlsStepper(good)
                if rng.random() < 0.8:
                    x.first_flight()
                ts.append(x)
            except OSError:
                pass
        for _ in range(rng.randint(0, 20)):
            d.signal(signal.SIGHUP)
            time.sleep(rng.uniform(0, 0.01))
        for x in ts:
            try:
                if x.obj.pending == 0 and not x.out.pending and x.sock:
                    pass
                sec = x.read_server_flight()
                x.sock.sendall(sec)
                x.send(frame(HELLO, hello(1), 1))
                frames, closed, alert = x.recv_frames(0.5)
                wel += len([f for f in frames if f.type == WELCOME])
            except Exception:
                pass
            x.sock.close()
        if d.p.poll() is not None:
            fails.append("B: ajard died with %s" % d.p.returncode)
            break
    # liveness after the storms
    t = TlsStepper(good)
    t.first_flight()
    t.sock.sendall(t.read_server_flight())
    t.send(frame(HELLO, hello(1), 1) + frame(STOP, b"", 2))
    frames, closed, alert = t.recv_frames(2.0)
    say("B: storms done, %d welcomes; after: %s" % (wel, frames))
    if not any(f.type == ACK for f in frames):
        fails.append("B: no Stop Ack after the storms: %r" % frames)
finally:
    d.stop()
say("RESULT seed=%d fails=%d" % (seed, len(fails)))
for f in fails:
    say("  ", f)
