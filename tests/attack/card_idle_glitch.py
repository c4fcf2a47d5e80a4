"""One failed status read (GT_GetSts) while the base is idle: what does Status say, and what
happens to the next Drive / Approach?   Usage: repro_idle_glitch.py [N failed calls]"""
import glob, os, struct, sys, time
from ajarwire import *
from simctl import SimCtl
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="idleglitch")
n = int(sys.argv[1]) if len(sys.argv) > 1 else 1
d.start()
try:
    c = d.conn(0)
    print("measure", measure_all(c, plane=False))
    ctl("FAIL GT_GetSts -1 %d" % n)
    time.sleep(0.5)
    st = c.status(); print("idle, %d failed read(s) 0.5 s ago: state=%s fault=%d card=%d" % (n, st["state"], st["fault"], st["card"]))
    m = c.call(DRIVE, drive(0.1, 0)); print("Drive ->", m)
    t = time.monotonic()
    while time.monotonic() - t < 0.5: c.call(DRIVE, drive(0.1, 0)); c.poll(0.05)
    print("events", [describe(x) for x in c.log if x.type == EVENT][-3:])
    st = c.status(); print("then: state=%s fault=%d card=%d" % (st["state"], st["fault"], st["card"]))
    print("Reset ->", c.call(RESET, b"\x00")); time.sleep(0.5)
    print("Drive ->", c.call(DRIVE, drive(0.1, 0))); time.sleep(0.3)
    st = c.status(); print("after Reset: state=%s fault=%d card=%d" % (st["state"], st["fault"], st["card"]))
    c.call(STOP)
finally:
    d.stop()
