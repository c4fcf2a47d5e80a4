#!/usr/bin/env python3
"""drivers.kind: mock with each arm fault of the menu: Engage, Stop, then Reset / Drive / Approach /
AlignBase: does the base move while the arm has not reported clear?  Usage: arm_mock_faults.py"""
import struct, time
from ajarwire import *
for fault in ("stuck", "slow", "error", "intermittent", "garbage"):
    d = Daemon({"drivers.kind": "mock", "arm_fault": fault, "slow_ms": 300}, name="armmock")
    d.start()
    try:
        c = d.conn(0)
        measure_all(c, plane=True)
        a = c.call(ALIGN)
        c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] in ("motion_finished", "fault_latched"), 15)
        cp = c.call(CONTACT, CONTACT_PT)
        e = c.call(ENGAGE)
        time.sleep(0.2)
        s = c.call(STOP)
        x0 = c.status()
        acc = []
        for k in range(30):
            for mt, pl in ((RESET, b"\x00"), (DRIVE, drive(0.1, 0.0)), (APPROACH, struct.pack("<d", 0.6)), (ALIGN, b"")):
                r = c.call(mt, pl, timeout=3)
                if ok(r) and mt != RESET:
                    acc.append((k, hex(mt)))
            time.sleep(0.05)
        x1 = c.status()
        say("arm_fault=%-12s engage %s stop %s; motion acks %s; odometry moved %.4f m, yaw %.4f; final %s fault=%d arm=%s" % (
            fault, "ACK" if ok(e) else err(e), "ACK" if ok(s) else err(s), acc[:4],
            x1["odo_x"] - x0["odo_x"], x1["yaw"] - x0["yaw"], x1["state"], x1["fault"], x1["arm"]))
    finally:
        d.stop()
