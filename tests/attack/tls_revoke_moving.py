#!/usr/bin/env python3
"""A TLS controller is revoked (new CRL + SIGHUP) while its Approach runs: the session is closed;
the motion must stop and DEADMAN (or another fault) latch; a new session of the same cert refused.
Usage: tls_revoke_moving.py [trials]"""
import os, signal, socket, ssl, struct, subprocess, sys, tempfile, time
from ajarwire import *
trials = int(sys.argv[1]) if len(sys.argv) > 1 else 3
pki = tempfile.mkdtemp(prefix="ajar-pki-")
mc = os.path.join(ROOT, "scripts", "make-certs")
run = lambda *a: subprocess.run([mc, "--dir", pki] + list(a), check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
run("ca"); run("daemon", "127.0.0.1"); run("operator", "wall", "observer")
names = ["op%d" % i for i in range(trials)]
for n in names: run("operator", n, "controller")
use_tls(pki, [(n, "controller") for n in names] + [("wall", "observer")])
d = Daemon({"drivers.kind": "sim"}, name="tlsmove"); d.start()
def tconn(name, role):
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    ctx.load_verify_locations(os.path.join(pki, "ca.crt"))
    ctx.load_cert_chain(os.path.join(pki, name + ".crt"), os.path.join(pki, name + ".key"))
    s = ctx.wrap_socket(socket.create_connection(("127.0.0.1", d.port)), server_hostname="127.0.0.1")
    c = Conn(d.port, sock=s); c.greet(role, take_over=True); return c
fails = 0
for t in range(trials):
    obs = tconn("wall", 1)
    obs.call(SUBSCRIBE, struct.pack("<f", 50.0))
    c = tconn(names[t], 0)
    c.call(STOP); time.sleep(0.3); c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    a = c.call(APPROACH, struct.pack("<d", 0.5))
    time.sleep(0.3)
    run("revoke", names[t]); d.signal(signal.SIGHUP)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 3:   # the revoked controller keeps pinging as fast as it can
        try: c.send(frame(PING, b"\0" * 8, 5)); c.poll(0.05)
        except OSError: break
    obs.poll(1.0)
    st = obs.status()
    evs = [(e[0], e[2]) for e in obs.events() if e[0] in ("fault_latched", "motion_stopped", "motion_finished", "control_changed")]
    tel = obs.telems()[-20:]
    moving = any(x["moving"] for x in tel[-5:])
    good = st["fault"] != 0 and not moving
    fails += not good
    say("%s trial %d: approach %s; revoked+SIGHUP; controller closed=%s; fault=%d moving=%s events=%s" % (
        "OK  " if good else "FAIL", t, "ACK" if ok(a) else a, c.closed, st["fault"], moving, evs[-4:]))
    obs.close(); c.close()
d.stop()
say("RESULT fails=%d" % fails)
