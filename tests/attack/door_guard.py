#!/usr/bin/env python3
"""Door guard (bbc0d45): jog forward toward a door measured 1.0 m ahead (width points). Where does
the base origin stop (must be >= approach_min_standoff_m 0.4 m, i.e. travel <= 0.6 m)? Variants:
straight; forward+turn arc; full-speed then re-measured width mid-jog (nearer door); forward after an
Approach to 0.45.  Usage: door_guard.py [kind]"""
import struct, sys, time
from ajarwire import *
kind = sys.argv[1] if len(sys.argv) > 1 else "sim"
d = Daemon({"drivers.kind": kind, "sim.speedup" if False else "speedup": 1.0}, name="guard")
d.start()
for variant in (sys.argv[2:] or ["straight", "arc", "remeasure-nearer", "after-approach"]):
    c = d.conn(0, take_over=True)
    c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x01")
    # re-measure the door 1.0 m ahead of the base's *current* pose: points are in the base frame
    measure_all(c, plane=False)
    x0 = c.status()
    if variant == "after-approach":
        c.call(APPROACH, struct.pack("<d", 0.45))
        for _ in range(200):
            c.call(PING, b"\0" * 8)
            if c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] in ("motion_finished", "fault_latched"), 0.1):
                break
    first = None
    t0 = time.monotonic()
    replies = {}
    while time.monotonic() - t0 < 12:
        v, w = (0.3, 0.0) if variant != "arc" else (0.3, 0.15)
        r = c.call(DRIVE, drive(v, w))
        k = "ACK" if ok(r) else err(r); replies[k] = replies.get(k, 0) + 1
        if variant == "remeasure-nearer" and 2.0 < time.monotonic() - t0 < 2.15:
            # width points now 0.6 m ahead of the base (the operator re-picks a nearer edge)
            m = c.call(WIDTH, pt(0.6, 0.45, 0.9) + pt(0.6, -0.45, 0.9))
            replies["width@2s"] = "ACK" if ok(m) else err(m)
        time.sleep(0.08)
    x1 = c.status()
    import math
    travel = math.hypot(x1["odo_x"] - x0["odo_x"], x1["odo_y"] - x0["odo_y"])
    evs = [(e[0], e[2], e[3][:70]) for e in c.events() if e[0] in ("motion_started", "fault_latched")][-3:]
    say("%-17s travel %.3f m (door at 1.0 m, standoff 0.4 => at most 0.600); fault %d; replies %s; %s" % (variant, travel, x1["fault"], replies, evs))
    c.call(STOP); c.close()
d.stop()
