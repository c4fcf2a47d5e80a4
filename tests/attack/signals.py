#!/usr/bin/env python3
"""Signal orderings during a jog: SIGTERM+SIGTERM, SIGTERM+SIGINT, SIGTERM+SIGHUP, SIGHUP storm then
SIGTERM. Exit code, time to exit, and after a restart: fault latched? Drive refused?
Usage: signals.py"""
import signal, struct, time
from ajarwire import *
d = Daemon({"drivers.kind": "sim"}, name="signals")
d.start()
for seq in (["TERM", "TERM"], ["TERM", "INT"], ["TERM", "HUP", "HUP"], ["HUP"] * 10 + ["TERM"], ["INT"]):
    c = d.conn(0, take_over=True)
    c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    for _ in range(5):
        c.call(DRIVE, drive(0.2, 0.0)); time.sleep(0.05)
    t0 = time.monotonic()
    for s in seq:
        d.signal(getattr(signal, "SIG" + s)); time.sleep(0.002)
    e = c.call(ESTOP, timeout=3)
    rc = d.p.wait(30)
    dt = time.monotonic() - t0
    d.start()
    c2 = d.conn(0)
    st = c2.status()
    r = c2.call(DRIVE, drive(0.1, 0.0))
    say("%-28s estop %s; exit %s after %.2f s; restart fault=%d Drive->%s" % ("+".join(seq), "ACK" if ok(e) else e, rc, dt, st["fault"], "ACK" if ok(r) else err(r)))
    c2.call(STOP); c2.close()
d.stop()
