#!/usr/bin/env python3
"""Item 1: Approach / jog / turn with a small drive.max_linear_speed_m_s: never faster at the wheels.

Usage: approach_speed.py [sim|mock] [trials]
Telemetry at 500 Hz; wheel speed from successive wheel positions (rad) x R_W, body speed from
odometry. Also: an Approach re-issued at hostile instants (during the jog ramp, right after a Stop).
"""
import os
import struct
import sys
import time

from ajarwire import *

kind = sys.argv[1] if len(sys.argv) > 1 else "sim"
trials = int(sys.argv[2]) if len(sys.argv) > 2 else 3
VMAX, AMAX, RW = 0.02, 0.05, 0.10
WIN = float(os.environ.get("WIN", "0.1"))

d = Daemon({"drivers.kind": kind, "max_linear_speed_m_s": VMAX, "max_linear_accel_m_s2": AMAX,
            "approach_max_travel_m": 1.5, "approach_min_standoff_m": 0.4,
            "stall_timeout_s": 0.5}, name="speed")
d.start()
worst = [0.0, 0.0]
fail = 0


def speeds(tel):
    vmax = amax = 0.0
    prev = None
    vs = []
    for t in tel:
        if prev is not None:
            dt = (t["t_ns"] - prev["t_ns"]) * 1e-9
            if dt <= 0:
                continue
            vl = (t["left_rad"] - prev["left_rad"]) * RW / dt
            vr = (t["right_rad"] - prev["right_rad"]) * RW / dt
            vs.append((t["t_ns"], max(abs(vl), abs(vr))))
        prev = t
    # velocity from positions >= WIN s apart (telemetry stamps jitter on a loaded machine)
    out = []
    j = 0
    for i in range(len(tel)):
        while j < len(tel) and (tel[j]["t_ns"] - tel[i]["t_ns"]) * 1e-9 < WIN:
            j += 1
        if j >= len(tel):
            break
        a, b = tel[i], tel[j]
        dt = (b["t_ns"] - a["t_ns"]) * 1e-9
        v = max(abs(b["left_rad"] - a["left_rad"]), abs(b["right_rad"] - a["right_rad"])) * RW / dt
        out.append(((a["t_ns"] + b["t_ns"]) * 0.5e-9, v))
    for v in out:
        vmax = max(vmax, v[1])
    k = 0
    for i in range(len(out)):
        while k < len(out) and out[k][0] - out[i][0] < WIN:
            k += 1
        if k >= len(out):
            break
        amax = max(amax, abs(out[k][1] - out[i][1]) / (out[k][0] - out[i][0]))
    return vmax, amax


try:
    for trial in range(trials):
        c = d.conn(0, take_over=True)
        c.call(RESET, b"\x01")
        m = measure_all(c, plane=False)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 500.0))
        # alternate: plain approach; approach right after a jog; approach right after Stop
        variant = trial % 3
        if variant == 1:
            c.call(DRIVE, drive(1.0, 0.0))  # asks 50x the limit
            time.sleep(0.3)
            c.call(DRIVE, drive(0.0, 0.0))
            c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] == "motion_finished", 10)
        if variant == 2:
            c.call(DRIVE, drive(-5.0, 0.0))
            time.sleep(0.2)
            c.call(STOP)
            c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] in ("motion_stopped",
                                                                         "motion_finished"), 10)
        a = c.call(APPROACH, struct.pack("<d", 0.85))
        say("trial", trial, "variant", variant, "approach ->", a)
        t0 = time.monotonic()
        while time.monotonic() - t0 < float(os.environ.get("OBS", "6")):
            c.call(PING, struct.pack("<Q", 0))
            c.poll(0.1)
            obs.poll(0.0)
            ev = [e for e in c.events() if e[0] in ("motion_finished", "motion_stopped",
                                                     "fault_latched")]
            if ok(a) and ev and ev[-1][0] != "motion_started":
                pass
        obs.poll(0.3)
        tel = obs.telems()
        vmax, amax = speeds(tel)
        cmdmax = max([abs(t["cmd_v"]) for t in tel] + [0])
        say("  telemetry frames %d, wheel speed max %.4f m/s (limit %.3f), accel max %.3f m/s2 "
            "(limit %.3f), commanded max %.4f" % (len(tel), vmax, VMAX, amax, AMAX, cmdmax))
        say("  events:", c.events()[-4:])
        if vmax > VMAX * 1.10:
            fail += 1
            say("  FAIL: faster than the limit")
        worst = [max(worst[0], vmax), max(worst[1], amax)]
        obs.close()
        c.close()
        time.sleep(0.3)
finally:
    d.stop()
say("RESULT kind=%s trials=%d fail=%d worst speed %.4f accel %.3f" % (kind, trials, fail,
                                                                     worst[0], worst[1]))
