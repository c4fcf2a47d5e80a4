#!/usr/bin/env python3
"""Items 7, 8 (and more): card misbehaviour injected into a running ajard on the card simulator.

Usage: card_faults.py CASE [trials]
  jogmiss     jog at 0.2 m/s, then GT_SetVel accepted-not-applied (gdb: AjarSim_FailNextCalls
              ("GT_SetVel", 0, -1)), the command ramps to zero: fault within the jog's deadline?
              card emergency-stopped?
  jogmiss-up  same, but the command goes *down* to 0.05 m/s (not zero) and stays there
  stopdrop    GT_Stop accepted-not-applied (smooth and emergency stop use GT_Stop): Stop, then
              EmergencyStop during a jog: does the base stop (another path: GT_AxisOff)? fault?
  stall       AJAR_SIM_BLOCK_FILE: the next GT_* call hangs mid-jog / mid-approach: base stopped
              by the other path, LOOP_STALLED latched, Reset refused while stalled?
Faults are injected with gdb (attach, call the simulator's control function, detach).
"""
import os
import struct
import subprocess
import sys
import time

from ajarwire import *

case = sys.argv[1]
trials = int(sys.argv[2]) if len(sys.argv) > 2 else 2
blockfile = "/tmp/ajar-attack-block-%d" % os.getpid()
import glob
SIMLIB = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
SHIM = "/tmp/simctl_preload.so"
subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-o", SHIM,
                os.path.join(os.path.dirname(__file__), "simctl_preload.c"), "-ldl", "-lpthread"],
               check=True)
CTL = "/tmp/ajar-attack-simctl-%d" % os.getpid()
env = {"LD_PRELOAD": SHIM, "AJAR_SIMCTL": CTL, "AJAR_SIMLIB": SIMLIB}
if case == "stall":
    env["AJAR_SIM_BLOCK_FILE"] = blockfile
d = Daemon({"drivers.kind": "sim", "stall_timeout_s": 0.3}, env=env, name=case)


def gdb_call(line):
    """(named for history: gdb inferior calls fail here) -> the LD_PRELOAD shim's control file"""
    with open(CTL + ".tmp", "w") as f:
        f.write(line + "\n")
    os.rename(CTL + ".tmp", CTL)
    end = time.monotonic() + 2
    while os.path.exists(CTL) and time.monotonic() < end:
        time.sleep(0.005)
    return "applied" if not os.path.exists(CTL) else "NOT applied"


FAIL = "FAIL"
fails = []


def speed(tel, a, b):
    if b - a < 2:
        return 0.0
    x, y = tel[a], tel[b - 1]
    dt = (y["t_ns"] - x["t_ns"]) * 1e-9
    return abs(y["left_rad"] - x["left_rad"]) * 0.1 / dt if dt > 0 else 0.0


try:
    d.start()
    for trial in range(trials):
        c = d.conn(0, take_over=True)
        c.call(RESET, b"\x01")
        measure_all(c, plane=False)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
        t_start = time.monotonic()
        c.call(DRIVE, drive(0.2, 0.0)) if case != "stall" or trial % 2 == 0 else \
            c.call(APPROACH, struct.pack("<d", 0.5))
        for _ in range(10):
            c.call(DRIVE, drive(0.2, 0.0)) if case != "stall" or trial % 2 == 0 else c.call(PING, b"\0" * 8)
            time.sleep(0.1)
        if case in ("jogmiss", "jogmiss-up"):
            out = gdb_call('FAIL GT_SetVel 0 -1')
            say("trial %d: injected GT_SetVel accepted-not-applied %s" % (trial, out))
            target = 0.0 if case == "jogmiss" else 0.05
            t0 = time.monotonic()
            while time.monotonic() - t0 < 6:
                c.call(DRIVE, drive(target, 0.0))
                time.sleep(0.1)
        elif case == "stopdrop":
            out = gdb_call('FAIL GT_Stop 0 -1')
            say("trial %d: injected GT_Stop accepted-not-applied %s" % (trial, out))
            s = c.call(STOP)
            time.sleep(1.0)
            e = c.call(ESTOP)
            say("  Stop %s, EmergencyStop %s" % (s, e))
            t0 = time.monotonic()
            while time.monotonic() - t0 < 5:
                c.call(PING, b"\0" * 8)
                time.sleep(0.1)
        elif case == "stall":
            open(blockfile, "w").close()
            t0 = time.monotonic()
            while time.monotonic() - t0 < 1.5:
                c.call(PING, b"\0" * 8)
                time.sleep(0.05)
            r = c.call(RESET, b"\x00", timeout=2)
            dr = c.call(DRIVE, drive(0.1, 0.0), timeout=2)
            say("trial %d: stalled; Reset during stall -> %s; Drive -> %s" % (trial, r, dr))
            os.unlink(blockfile)
            time.sleep(1.0)
        obs.poll(0.2)
        tel = obs.telems()
        n = len(tel)
        # wheel speed in the last second of telemetry
        last = speed(tel, max(0, n - 100), n)
        st = c.status()
        evs = [e for e in c.events() if e[0] in ("fault_latched", "motion_stopped",
                                                   "motion_finished")]
        say("  after: status %s fault=%d; wheel speed over the last ~1 s %.3f m/s; events %s" % (
            st["state"], st["fault"], last, evs))
        # when did the wheels stop moving (first 0.2 s window below 1 mm/s after injection)?
        if case != "stall":
            gdb_call('FAIL * 0 0')
            gdb_call('FAIL GT_SetVel 0 0')
            gdb_call('FAIL GT_Stop 0 0')
        if last > 0.005 or st["fault"] == 0:
            fails.append("trial %d: speed %.3f fault %d" % (trial, last, st["fault"]))
        r = c.call(RESET, b"\x00")
        say("  Reset after -> %s" % r)
        c.close()
        obs.close()
finally:
    d.stop()
    if os.path.exists(blockfile):
        os.unlink(blockfile)
say("RESULT case=%s trials=%d fails=%d" % (case, trials, len(fails)))
for f in fails:
    say("  ", f)
