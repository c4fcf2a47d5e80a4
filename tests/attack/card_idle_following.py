"""A drive fault reported while the base is idle, then cleared by the drive itself: what does
Status say, and what happens to the next Drive?   Usage: card_idle_following.py KIND
(KIND: 2 following error, 1 drive alarm; AjarSim_InjectFault on axis 2)"""
import struct, sys, time
from ajarwire import *
from simctl import SimCtl
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="feidle"); d.start()
try:
    c = d.conn(0); measure_all(c, plane=False)
    ctl("FAULT 2 %s" % sys.argv[1]); time.sleep(0.3)
    st = c.status(); print("flag set, idle: state=%s fault=%d card=%d" % (st["state"], st["fault"], st["card"]))
    ctl("FAULT 2 0"); time.sleep(0.3)
    st = c.status(); print("flag cleared by the drive: state=%s fault=%d card=%d" % (st["state"], st["fault"], st["card"]))
    print("Drive ->", c.call(DRIVE, drive(0.1, 0))); time.sleep(0.3); c.poll(0.1)
    print("events", [describe(m) for m in c.log if m.type == EVENT][-3:])
finally:
    d.stop()
