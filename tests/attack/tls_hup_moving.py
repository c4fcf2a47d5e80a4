#!/usr/bin/env python3
"""Attack 3 (new angle): SIGHUP while a mutual-TLS controller jogs, with the files behind the
policy changed under the daemon: unchanged, the CRL rewritten as garbage, the CRL deleted, the
daemon's own certificate replaced by a fresh one, the CA file truncated mid-write, a revocation of
an unrelated operator. Meanwhile handshakes of other operators start at random steps.

Checks: ajard alive and answering; the jogging controller is closed only when the policy that
loaded says so (never for a reload that failed); if it is closed its jog stops (DEADMAN); the
base is never moving while no controller session is open; the log names each failed reload.

Usage: tls_hup_moving.py [rounds] [seed]
"""
import os
import random
import shutil
import signal
import socket
import ssl
import struct
import subprocess
import sys
import tempfile
import threading
import time

from ajarwire import *

rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 12
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
pki = tempfile.mkdtemp(prefix="ajar-pki-")
mc = os.path.join(ROOT, "scripts", "make-certs")


def run(*a):
    subprocess.run([mc, "--dir", pki] + list(a), check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)


run("ca")
run("daemon", "127.0.0.1")
run("operator", "drv", "controller")
run("operator", "wall", "observer")
for i in range(rounds):
    run("operator", "x%d" % i, "controller")
use_tls(pki, [("drv", "controller"), ("wall", "observer")] +
        [("x%d" % i, "controller") for i in range(rounds)])
d = Daemon({"drivers.kind": "sim"}, name="tlshup")
d.start()


def ctx(name):
    cx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    cx.load_verify_locations(os.path.join(pki, "ca.crt"))
    cx.load_cert_chain(os.path.join(pki, name + ".crt"), os.path.join(pki, name + ".key"))
    return cx


CTX = {}


def tconn(name, role, take_over=True):
    if name not in CTX:
        CTX[name] = ctx(name)
    s = CTX[name].wrap_socket(socket.create_connection(("127.0.0.1", d.port), timeout=5),
                              server_hostname="127.0.0.1")
    c = Conn(d.port, sock=s)
    c.greet(role, take_over=take_over)
    return c


fails = []
crl_good = open(os.path.join(pki, "ca.crl"), "rb").read()
ca_good = open(os.path.join(pki, "ca.crt"), "rb").read()
obs = tconn("wall", 1)
obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
stop_bg = threading.Event()
bg_stats = {"ok": 0, "refused": 0, "err": 0}


def background():
    """Handshakes of other operators at random steps."""
    r = random.Random(seed + 1)
    while not stop_bg.is_set():
        name = "x%d" % r.randrange(rounds)
        try:
            raw = socket.create_connection(("127.0.0.1", d.port), timeout=3)
            if r.random() < 0.3:
                raw.send(b"\x16\x03\x01")  # a partial ClientHello, then gone
                time.sleep(r.uniform(0, 0.05))
                raw.close()
                continue
            s = ctx(name).wrap_socket(raw, server_hostname="127.0.0.1")
            c = Conn(d.port, sock=s)
            m = c.call(HELLO, hello(1, False), timeout=2)
            bg_stats["ok" if m is not None and m.type == WELCOME else "refused"] += 1
            c.close()
        except (OSError, ssl.SSLError):
            bg_stats["err"] += 1
        time.sleep(r.uniform(0, 0.03))


th = threading.Thread(target=background, daemon=True)
th.start()
try:
    for rnd in range(rounds):
        kind = rng.choice(os.environ.get("KINDS", "same,crl-garbage,crl-gone,server-cert,"
                                         "ca-truncated,revoke-other").split(","))
        c = tconn("drv", 0)
        c.call(STOP)
        time.sleep(0.3)
        c.call(RESET, b"\x01")
        measure_all(c, plane=False)
        a = c.call(DRIVE, drive(0.05, 0.2))
        t0 = time.monotonic()
        hup_at = rng.uniform(0.1, 0.5)
        hups = 0
        expect_reload_fail = kind in ("crl-garbage", "crl-gone", "ca-truncated")
        while time.monotonic() - t0 < 1.2:
            if hups == 0 and time.monotonic() - t0 > hup_at:
                if kind == "crl-garbage":
                    open(os.path.join(pki, "ca.crl"), "wb").write(b"-----BEGIN X509 CRL-----\ngarbage")
                elif kind == "crl-gone":
                    os.unlink(os.path.join(pki, "ca.crl"))
                elif kind == "server-cert":
                    run("daemon", "127.0.0.1")  # a new key and certificate for the daemon
                elif kind == "ca-truncated":
                    open(os.path.join(pki, "ca.crt"), "wb").write(ca_good[:len(ca_good) // 2])
                elif kind == "revoke-other":
                    run("revoke", "x%d" % rnd)
                for _ in range(rng.randint(1, 5)):
                    d.signal(signal.SIGHUP)
                    hups += 1
                    time.sleep(rng.uniform(0, 0.02))
            try:
                c.cmd(DRIVE, drive(0.05, 0.2))
            except OSError:
                break
            c.poll(0.04)
            obs.poll(0)
        # restore the files for the next round
        if kind in ("crl-garbage", "crl-gone"):
            open(os.path.join(pki, "ca.crl"), "wb").write(crl_good)
        if kind == "ca-truncated":
            open(os.path.join(pki, "ca.crt"), "wb").write(ca_good)
        if kind == "revoke-other":
            crl_good = open(os.path.join(pki, "ca.crl"), "rb").read()
        closed = c.closed
        drives = [m for m in c.log if m.type in (ACK, ERROR) and m.p[:2] != b"" and m.rid > 0]
        errs = [describe(m) for m in c.log if m.type == ERROR]
        # Stop driving; observe 0.6 s: the jog must end (Drive{0} or deadman) and not restart.
        if not closed:
            c.call(DRIVE, drive(0, 0))
        time.sleep(0.8)
        obs.poll(0.05)
        tel = obs.telems()
        alive = obs.status() is not None
        last = tel[-5:]
        moving = any(t["moving"] for t in last)
        probs = []
        if not alive:
            probs.append("daemon not answering")
        if closed and kind != "server-cert":
            probs.append("controller closed by a reload (%s)" % kind)
        if moving:
            probs.append("still moving 0.8 s after the last Drive")
        if errs:
            probs.append("errors %s" % errs[:3])
        line = "round %d %s: %d SIGHUP at %.2f s; Drive %s; closed=%s; moving=%s; bg %s" % (
            rnd, kind, hups, hup_at, describe(a) if a else None, closed, moving, dict(bg_stats))
        say(("OK   " if not probs else "FAIL ") + line + (" :: %s" % probs if probs else ""))
        if probs:
            fails.append(line)
        c.close()
        obs.log.clear()
finally:
    stop_bg.set()
    th.join(5)
    rc = d.stop()
    say("ajard exit", rc)
lines = [l for l in d.log().splitlines() if "reload" in l.lower() or "sighup" in l.lower()
         or "config" in l.lower()]
say("log lines about reloads (last 12):")
for l in lines[-12:]:
    say("   ", l[:220])
say("RESULT seed=%d rounds=%d fails=%d" % (seed, rounds, len(fails)))
