#!/usr/bin/env python3
"""A jog whose wheel speeds exceed base.max_wheel_speed_rad_s: does the base keep the commanded
path (curvature w/v) and stay within the wheel limit, or is each wheel clipped (a different path)?
Also compares Telemetry commanded_* with what the wheels do.  Usage: jog_curvature.py [sim|mock]"""
import struct, sys, time
from ajarwire import *
kind = sys.argv[1] if len(sys.argv) > 1 else "sim"
RW, RB, WMAX = 0.10, 0.25, 1.0
d = Daemon({"drivers.kind": kind}, name="curv")
d.start()
c = d.conn(0)
obs = d.conn(1)
obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
measure_all(c, plane=False)
for v, w in ((0.2, 0.3), (0.3, 0.6), (0.05, 0.6), (-0.3, 0.2), (0.3, -0.6)):
    c.call(STOP); obs.poll(1.0); c.call(RESET, b"\x00")
    for _ in range(20):
        c.call(DRIVE, drive(v, w)); obs.poll(0.1)
    obs.log.clear()
    for _ in range(10):
        c.call(DRIVE, drive(v, w)); obs.poll(0.1)
    tel = [parse_telem(m.p) for m in obs.log if m.type == TELEM]
    a, b = tel[0], tel[-1]
    dt = (b["t_ns"] - a["t_ns"]) * 1e-9
    wl = (b["left_rad"] - a["left_rad"]) / dt; wr = (b["right_rad"] - a["right_rad"]) / dt
    vb = (wl + wr) / 2 * RW; wb = (wr - wl) / 2 * RW / RB
    cv, cw = b["cmd_v"], b["cmd_w"]
    k_cmd = w / v if v else float("inf"); k_real = wb / vb if abs(vb) > 1e-6 else float("inf")
    say("Drive(%.2f, %.2f): telemetry commanded (%.3f, %.3f); wheels %.2f / %.2f rad/s (limit %.1f); body (%.3f m/s, %.3f rad/s); curvature asked %.2f, driven %.2f" % (
        v, w, cv, cw, wl, wr, WMAX, vb, wb, k_cmd, k_real))
c.call(STOP)
d.stop()
