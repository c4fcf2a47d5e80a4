#!/usr/bin/env python3
"""Reset (keep / clear parameters) during a jog, an Approach and an AlignBase; and Reset racing an
EmergencyStop in one write, both orders. What happens to the motion?  Usage: reset_motion.py"""
import struct, time
from ajarwire import *
d = Daemon({"drivers.kind": "sim"}, name="resetmotion")
d.start()
obs = d.conn(1)
obs.call(SUBSCRIBE, struct.pack("<f", 50.0))
for motion in ("jog", "approach", "align"):
    for clear in (b"\x00", b"\x01"):
        c = d.conn(0, take_over=True)
        c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x01")
        measure_all(c, plane=(motion == "align"))
        if motion == "jog":
            m = c.call(DRIVE, drive(0.2, 0.3))
        elif motion == "approach":
            m = c.call(APPROACH, struct.pack("<d", 0.5))
        else:
            m = c.call(ALIGN)
        time.sleep(0.3)
        n0 = len(c.log)
        r = c.call(RESET, clear)
        t = time.monotonic()
        for _ in range(15):
            if motion == "jog": c.call(DRIVE, drive(0.2, 0.3))
            else: c.call(PING, b"\0" * 8)
            obs.poll(0.1)
        tel = [parse_telem(x.p) for x in obs.log if x.type == TELEM and x.t > t + 0.8]
        obs.log.clear()
        mv = tel[-1]["moving"] if tel else None
        evs = [parse_event(x.p)[0:3:2] + (parse_event(x.p)[3][:50],) for x in c.log[n0:] if x.type == EVENT]
        say("%-8s Reset(clear=%d) mid-motion -> %s; moving 1 s later=%s; events %s" % (motion, clear[0], "ACK " + STATES[r.p[2]] if ok(r) else err(r), mv, evs[:4]))
        c.close()
# Reset and EmergencyStop racing in one write, while jogging
for order in ("RE", "ER"):
    c = d.conn(0, take_over=True)
    c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x01"); measure_all(c, plane=False)
    c.call(DRIVE, drive(0.2, 0.0)); time.sleep(0.2)
    fr, rr = c.req(RESET, b"\x00"); fe, re_ = c.req(ESTOP)
    c.send(fr + fe if order == "RE" else fe + fr)
    a, b = c.reply(rr), c.reply(re_)
    st = c.status()
    say("one write %s: Reset %s EmergencyStop %s -> fault %d" % (order, a, b, st["fault"]))
    c.close()
d.stop()
