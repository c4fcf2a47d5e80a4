#!/usr/bin/env python3
"""mock arm_fault: intermittent (every third arm call fails with a communication error): Engage,
Stop at a chosen delay; timeline of events and status. An acked Stop whose arm stop failed must not
let the arm task run on to 'engaged' without a fault.  Usage: arm_intermittent.py [stop_delay_ms...]"""
import struct, sys, time
from ajarwire import *
delays = [float(x) for x in sys.argv[1:]] or [0, 50, 200, 500]
for dl in delays:
    for fault in ("intermittent",):
        d = Daemon({"drivers.kind": "mock", "arm_fault": fault}, name="armint")
        d.start()
        try:
            c = d.conn(0)
            measure_all(c, plane=True)
            c.call(ALIGN)
            c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] in ("motion_finished", "fault_latched"), 15)
            c.call(CONTACT, CONTACT_PT)
            T0 = time.monotonic()
            e = c.call(ENGAGE)
            time.sleep(dl / 1e3)
            s = c.call(STOP)
            sts = []
            for _ in range(30):
                st = c.status(); sts.append((round(time.monotonic() - T0, 2), st["state"], st["fault"], st["arm"]))
                time.sleep(0.1)
            dedup = [x for i, x in enumerate(sts) if i == 0 or x[1:] != sts[i - 1][1:]]
            say("stop %g ms after Engage: engage %s stop %s (at %.2f s)" % (dl, e, s, s.t - T0))
            say("   status changes:", dedup)
            say("   events:", [(round(m.t - T0, 2),) + parse_event(m.p)[:3] + (parse_event(m.p)[3][:70],) for m in c.log if m.type == EVENT and m.t >= T0])
            say("   log:", [l[24:140] for l in d.log().splitlines() if "arm" in l.lower()][-8:])
        finally:
            d.stop()
