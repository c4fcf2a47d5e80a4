#!/usr/bin/env python3
"""ajard itself is frozen (SIGSTOP: a VM pause, a debugger, swap storm) for PAUSE s during a jog /
an Approach while the controller keeps sending. After SIGCONT: how far did the base go unattended,
is a fault latched (DEADMAN / LOOP_STALLED / ...)?  Usage: daemon_pause.py [pause_s]"""
import signal, struct, sys, time
from ajarwire import *
pause = float(sys.argv[1]) if len(sys.argv) > 1 else 3.0
d = Daemon({"drivers.kind": "sim"}, name="pause")
d.start()
for motion in ("jog", "approach"):
    c = d.conn(0, take_over=True)
    c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x01"); measure_all(c, plane=False)
    x0 = c.status()
    if motion == "jog":
        for _ in range(5): c.call(DRIVE, drive(0.2, 0.0)); time.sleep(0.05)
    else:
        c.call(APPROACH, struct.pack("<d", 0.4))
    time.sleep(0.3)
    n0 = len(c.log)
    d.signal(signal.SIGSTOP)
    t0 = time.monotonic()
    while time.monotonic() - t0 < pause:
        f, _ = c.req(DRIVE, drive(0.2, 0.0)) if motion == "jog" else c.req(PING, b"\0" * 8)
        c.send(f); time.sleep(0.1)
    d.signal(signal.SIGCONT)
    c.poll(1.5)
    x1 = c.status()
    evs = [parse_event(m.p)[0:3:2] + (parse_event(m.p)[3][:60],) for m in c.log[n0:] if m.type == EVENT]
    say("%s: paused %.1f s; travel %.3f m; fault after %d; events %s" % (motion, pause, x1["odo_x"] - x0["odo_x"], x1["fault"], evs))
    c.call(STOP); c.close()
d.stop()
