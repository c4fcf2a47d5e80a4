"""A drive fault on axis 2 while a Stop brings a jog to rest (KIND 2 following error, 1 drive
alarm), with `clear`: cleared by the drive 20 ms later, before the wheels rest. Status after,
and the next Drive.   Usage: card_stop_drive_fault.py KIND [clear]"""
import struct, sys, time
from ajarwire import *
from simctl import SimCtl
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="festop"); d.start()
try:
    c = d.conn(0); measure_all(c, plane=False)
    t = time.monotonic()
    while time.monotonic() - t < 0.8: c.call(DRIVE, drive(0.3, 0)); c.poll(0.04)
    c.cmd(STOP); ctl("FAULT 2 %s" % sys.argv[1])
    if sys.argv[2:] == ["clear"]: time.sleep(0.02); ctl("FAULT 2 0")
    time.sleep(1.0)
    st = c.status(); print("after: state=%s fault=%d card=%d" % (st["state"], st["fault"], st["card"]))
    print("Drive ->", c.call(DRIVE, drive(0.1, 0))); time.sleep(0.3); c.poll(0.1)
    print("events", [describe(m) for m in c.log if m.type == EVENT][-3:])
finally:
    d.stop()
