#!/usr/bin/env python3
"""A card that accepts GT_Stop (smooth and emergency) and does not apply it, during a jog.

Usage: stop_dropped.py [estop_first|stop_only|setvel]
Prints the wheel speed timeline (telemetry, 100 Hz) against the daemon's events and replies:
Stop, EmergencyStop, then Reset and a Drive. The safety rules want: the base stopped by another
path (or at least: a fault latched that says the wheels are still moving, Reset refused while
they move, nothing reported as "stopped" while it moves).
"""
import glob
import os
import struct
import subprocess
import sys
import time

from ajarwire import *

estop_first = len(sys.argv) > 1 and sys.argv[1] == "estop_first"
stop_only = len(sys.argv) > 1 and sys.argv[1] == "stop_only"
setvel = len(sys.argv) > 1 and sys.argv[1] == "setvel"
SIMLIB = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
SHIM = "/tmp/simctl_preload.so"
subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-o", SHIM,
                os.path.join(os.path.dirname(__file__), "simctl_preload.c"), "-ldl", "-lpthread"],
               check=True)
CTL = "/tmp/ajar-attack-simctl-%d" % os.getpid()
d = Daemon({"drivers.kind": "sim"}, env={"LD_PRELOAD": SHIM, "AJAR_SIMCTL": CTL,
                                         "AJAR_SIMLIB": SIMLIB}, name="stopdrop")


def simctl(line):
    with open(CTL + ".tmp", "w") as f:
        f.write(line + "\n")
    os.rename(CTL + ".tmp", CTL)
    while os.path.exists(CTL):
        time.sleep(0.005)


marks = []
try:
    d.start()
    c = d.conn(0)
    obs = d.conn(1)
    obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
    measure_all(c, plane=False)
    T0 = time.monotonic()
    for _ in range(8):
        c.call(DRIVE, drive(0.2, 0.0))
        obs.poll(0.1)
    simctl("FAIL GT_SetVel 0 -1" if setvel else ("FAIL GT_Stop 0 1" if os.environ.get("ONCE") else "FAIL GT_Stop 0 -1"))
    marks.append((time.monotonic() - T0, "GT_SetVel/GT_Stop now accepted-not-applied"))
    if setvel:
        marks.append((time.monotonic() - T0, "Drive(0) -> %r" % c.call(DRIVE, drive(0.0, 0.0))))
        for _ in range(40):
            c.call(PING, b"\0" * 8)
            obs.poll(0.1)
    elif not estop_first:
        marks.append((time.monotonic() - T0, "Stop -> %r" % c.call(STOP)))
        for _ in range(15):
            c.call(PING, b"\0" * 8)
            obs.poll(0.1)
    if not stop_only and not setvel:
        marks.append((time.monotonic() - T0, "EmergencyStop -> %r" % c.call(ESTOP)))
    for _ in range(40):
        c.call(PING, b"\0" * 8)
        obs.poll(0.1)
    marks.append((time.monotonic() - T0, "Reset -> %r" % c.call(RESET, b"\x00")))
    obs.poll(0.3)
    marks.append((time.monotonic() - T0, "Drive -> %r" % c.call(DRIVE, drive(0.0, 0.3))))
    for _ in range(10):
        c.call(PING, b"\0" * 8)
        obs.poll(0.1)
    st = c.status()
    marks.append((time.monotonic() - T0, "Status %s" % st))
    obs.poll(0.2)
    for m in c.log:
        if m.type == EVENT:
            marks.append((m.t - T0, "Event %s" % (parse_event(m.p),)))
    tel = [(m.t - T0, parse_telem(m.p)) for m in obs.log if m.type == TELEM]
    # wheel speed every 0.25 s
    i = 0
    rows = []
    while i < len(tel):
        j = i
        while j < len(tel) and tel[j][0] - tel[i][0] < 0.25:
            j += 1
        if j >= len(tel):
            break
        a, b = tel[i][1], tel[j][1]
        dt = (b["t_ns"] - a["t_ns"]) * 1e-9
        rows.append((tel[i][0], "wheel speed %.3f m/s (left), %.3f (right); moving=%s cmd=%.3f" % (
            (b["left_rad"] - a["left_rad"]) * 0.1 / dt, (b["right_rad"] - a["right_rad"]) * 0.1 / dt,
            b["moving"], b["cmd_v"])))
        i = j
    for t, s in sorted(marks + rows):
        say("%6.2f %s" % (t, s))
    simctl("FAIL GT_Stop 0 0")
finally:
    d.stop()
