#!/usr/bin/env python3
"""UNCLEAN_SHUTDOWN must survive further restarts until a Reset: kill -9 mid-jog, then chains of
clean SIGTERM / kill -9 restarts (immediately after start, before any client) without Reset.
Usage: unclean_chain.py"""
import signal, time
from ajarwire import *
d = Daemon({"drivers.kind": "sim"}, name="unclean")
d.start()
c = d.conn(0)
measure_all(c, plane=False)
c.call(DRIVE, drive(0.2, 0.0)); time.sleep(0.2)
d.kill9()
bad = 0
for i, how in enumerate(["term", "kill-at-once", "term", "kill-after-0.2s", "kill-at-once", "term"]):
    d.start()
    if how == "kill-at-once":
        d.kill9()
    elif how == "kill-after-0.2s":
        time.sleep(0.2); d.kill9()
    else:
        d.stop()
    d.start()
    c = d.conn(0)
    st = c.status()
    r = c.call(DRIVE, drive(0.1, 0.0))
    good = st["fault"] != 0 and not ok(r)
    bad += not good
    say("%s restart %d (%s): fault=%d Drive->%s" % ("OK  " if good else "FAIL", i, how, st["fault"], "ACK" if ok(r) else err(r)))
    c.close(); d.stop()
say("RESULT fails=%d" % bad)
