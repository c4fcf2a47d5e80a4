#!/usr/bin/env python3
"""Does a healthy ajard (config/ajard.yaml defaults: control.stall_timeout_s 0.1, not realtime) latch
LOOP_STALLED on a loaded machine? Jogs back and forth with a 500 Hz telemetry subscriber for
DURATION s, counts LOOP_STALLED latches (Reset after each).  Usage: false_stall.py [duration_s]"""
import os, struct, sys, time
from ajarwire import *
dur = float(sys.argv[1]) if len(sys.argv) > 1 else 60
d = Daemon({"drivers.kind": "sim"}, name="falsestall")
d.start()
c = d.conn(0)
obs = d.conn(1)
obs.call(SUBSCRIBE, struct.pack("<f", 500.0))
measure_all(c, plane=False)
t0 = time.monotonic(); n = 0; i = 0
while time.monotonic() - t0 < dur:
    i += 1
    c.call(DRIVE, drive(0.1 if (i // 20) % 2 else -0.1, 0.0))
    obs.poll(0.05)
    obs.log.clear()
    st = [e for e in c.events() if e[0] == "fault_latched"]
    if st:
        n += len(st)
        say("%.1f s: %s (loadavg %s)" % (time.monotonic() - t0, st, open("/proc/loadavg").read().split()[:3]))
        c.log.clear()
        c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x00")
say("RESULT %.0f s, LOOP_STALLED/other faults latched: %d (loadavg %s)" % (dur, n, open("/proc/loadavg").read().split()[:3]))
d.stop()
