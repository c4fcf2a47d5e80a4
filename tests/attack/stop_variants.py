#!/usr/bin/env python3
"""Stop / EmergencyStop frames a newer or sloppy client might send during a jog: a reserved flag
bit, a newer minor version with a longer payload, a 1.0 frame, a payload in 1.1. Which ones stop
the base?  Usage: stop_variants.py"""
import struct, time
from ajarwire import *
d = Daemon({"drivers.kind": "mock"}, name="stopvar")
d.start()
cases = [("Stop (plain, baseline)", lambda rid: frame(STOP, b"", rid)),
         ("EmergencyStop (plain, baseline)", lambda rid: frame(ESTOP, b"", rid)),
         ("Stop flags=0x0002 (reserved bit)", lambda rid: frame(STOP, b"", rid, flags=2)),
         ("EmergencyStop flags=0x8000", lambda rid: frame(ESTOP, b"", rid, flags=0x8000)),
         ("Stop minor=2, 4-byte payload", lambda rid: frame(STOP, b"\0" * 4, rid, minor=2)),
         ("EmergencyStop minor=0", lambda rid: frame(ESTOP, b"", rid, minor=0)),
         ("EmergencyStop minor=1, 1-byte payload", lambda rid: frame(ESTOP, b"\x01", rid)),
         ("EmergencyStop minor=255", lambda rid: frame(ESTOP, b"", rid, minor=255))]
for name, mk in cases:
    c = d.conn(0, take_over=True)
    c.call(STOP); time.sleep(0.3); c.call(RESET, b"\x01"); measure_all(c, plane=False)
    for _ in range(3):
        c.call(DRIVE, drive(0.2, 0.0)); time.sleep(0.05)
    c.send(mk(4242))
    r = c.reply(4242, 2)
    for _ in range(4):  # keep jogging as a GUI holding the key would
        c.call(DRIVE, drive(0.2, 0.0)); time.sleep(0.05)
    x0 = c.status(); time.sleep(0.3); x1 = c.status()
    say("%-40s -> %-60s base still moving: %s (fault %d)" % (name, str(r)[:60], abs(x1["odo_x"] - x0["odo_x"]) > 1e-4, x1["fault"]))
    c.close()
d.stop()
