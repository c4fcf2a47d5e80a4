"""One card call answered with a communication error (-1) as a jog at 0.3 m/s ends: FN GT_Stop
with `stop` (the operator's Stop), FN GT_SetVel or GT_Update with `release` (Drive{0,0}). Status
after, and the next Drive.   Usage: card_stop_call_fails.py FN stop|release"""
import struct, sys, time
from ajarwire import *
from simctl import SimCtl
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="stopcallfail"); d.start()
try:
    c = d.conn(0); measure_all(c, plane=False)
    t = time.monotonic()
    while time.monotonic() - t < 0.8: c.call(DRIVE, drive(0.3, 0)); c.poll(0.04)
    ctl("FAIL %s -1 1" % sys.argv[1])
    print("Stop ->", c.call(STOP) if sys.argv[2] == "stop" else c.call(DRIVE, drive(0, 0)))
    t = time.monotonic()
    while time.monotonic() - t < 1.5: c.cmd(PING, b"\0"*8); c.poll(0.05)
    st = c.status(); print("after: state=%s fault=%d card=%d" % (st["state"], st["fault"], st["card"]))
    print("Drive ->", c.call(DRIVE, drive(0.1, 0))); time.sleep(0.3); c.poll(0.1)
    print("events", [describe(m) for m in c.log if m.type == EVENT][-3:])
finally:
    d.stop()
