"""The card falls silent (GT_GetSts fails N calls) while a Stop runs: is anything latched, and does
the next move start?  Usage: repro_silent_stop.py N [nofail]"""
import glob, os, struct, sys, time
from ajarwire import *
from simctl import SimCtl
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="silentstop")
n = int(sys.argv[1])
d.start()
try:
    c = d.conn(0); obs = d.conn(1); obs.call(SUBSCRIBE, struct.pack("<f", 50.0))
    print("measure", measure_all(c, plane=False))
    print("approach", c.call(APPROACH, struct.pack("<d", 0.5)))
    time.sleep(0.4)
    c.cmd(STOP)
    if sys.argv[2:] != ["nofail"]: ctl("FAIL GT_GetSts -1 %d" % n)
    t = time.monotonic()
    while time.monotonic() - t < 2.5: c.cmd(PING, b"\0"*8); c.poll(0.05)
    st = c.status(); print("after the stop:", {k: st[k] for k in ("state", "fault", "card")})
    print("events", [describe(m) for m in c.log if m.type == EVENT][-4:])
    ctl("FAIL GT_GetSts 0 0")
    print("status again", {k: v for k, v in c.status().items() if k in ("state", "fault", "card")})
    a2 = c.call(APPROACH, struct.pack("<d", 0.45))
    print("approach again", a2)
    t = time.monotonic()
    while time.monotonic() - t < 1.0: c.cmd(PING, b"\0"*8); c.poll(0.05)
    print("events", [describe(m) for m in c.log if m.type == EVENT][-4:])
    print("status", {k: v for k, v in c.status().items() if k in ("state", "fault", "card")})
finally:
    d.stop()
    print("\n".join(l[:220] for l in d.log().splitlines() if "warn" in l or "error" in l or "card" in l.lower()))
