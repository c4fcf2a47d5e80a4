#!/usr/bin/env python3
"""Items 4, 5, 6: a stop/fault across SIGTERM, SIGKILL and a rejected state file.

Usage: crash_latch.py MODE [trials] [seed]
  kill9-estop   EmergencyStop acked, SIGKILL 0..5 ms later; restart; fault latched? Drive refused?
  kill9-motion  SIGKILL at a random instant of a jog/approach; restart: fault latched? moves?
  term-estop    SIGTERM, then EmergencyStop 0..50 ms later (observer or controller, also several
                frames in one write); Ack? card e-stopped (wheels stop at once)? latched after restart?
  reject        EmergencyStop, SIGTERM, narrow limits.door_width_m so the state no longer validates,
                restart: fault latched? Drive refused until Reset?
"""
import os
import random
import signal
import struct
import sys
import time

from ajarwire import *

mode = sys.argv[1]
trials = int(sys.argv[2]) if len(sys.argv) > 2 else 10
seed = int(sys.argv[3]) if len(sys.argv) > 3 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
kind = os.environ.get("KIND", "sim")

d = Daemon({"drivers.kind": kind}, name=mode)
fails = []


def restart_check(d, trial, extra=None):
    """After a restart: the fault must be latched and nothing may move before Reset."""
    d.start(extra)
    c = d.conn(0)
    obs = d.conn(1)
    obs.call(SUBSCRIBE, struct.pack("<f", 200.0))
    st = c.status()
    r1 = c.call(DRIVE, drive(0.1, 0.0))
    r2 = c.call(APPROACH, struct.pack("<d", 0.6))
    time.sleep(0.4)
    obs.poll(0.1)
    tel = obs.telems()
    lw = [t["left_rad"] for t in tel]
    travel = (max(lw) - min(lw)) * 0.1 if lw else 0.0
    good = st["fault"] != 0 and not ok(r1) and not ok(r2) and travel < 1e-4
    line = "trial %d: after restart state=%s fault=%d restored=%s; Drive->%s Approach->%s travel=%.4f" % (
        trial, st["state"], st["fault"], st["restored"], r1, r2, travel)
    say(("  OK " if good else "  FAIL ") + line)
    if not good:
        fails.append(line)
    # leave the state clean for the next trial
    c.call(STOP)
    rr = c.call(RESET, b"\x01")
    c.close()
    obs.close()
    return st, rr


try:
    d.start()
    for trial in range(trials):
        c = d.conn(0, take_over=True)
        c.call(RESET, b"\x01")
        measure_all(c, plane=False)
        if mode == "kill9-estop":
            c.call(DRIVE, drive(0.2, 0.0))
            time.sleep(rng.uniform(0.05, 0.3))
            rid = c.cmd(ESTOP)
            m = c.reply(rid, 2)
            delay = rng.uniform(0, 0.005)
            time.sleep(delay)
            d.kill9()
            say("trial %d: estop %s, SIGKILL %.2f ms after the Ack" % (trial, m, delay * 1e3))
            restart_check(d, trial)
        elif mode == "kill9-motion":
            what = rng.choice(["jog", "approach"])
            if what == "jog":
                c.call(DRIVE, drive(0.2, 0.1))
            else:
                c.call(APPROACH, struct.pack("<d", 0.5))
            delay = rng.uniform(0, 1.0)
            t0 = time.monotonic()
            while time.monotonic() - t0 < delay:
                c.call(PING, struct.pack("<Q", 0))
                if what == "jog":
                    c.call(DRIVE, drive(0.2, 0.1))
                time.sleep(0.02)
            d.kill9()
            say("trial %d: %s, SIGKILL after %.3f s" % (trial, what, delay))
            restart_check(d, trial)
        elif mode == "term-estop":
            obs = d.conn(1)
            obs.call(SUBSCRIBE, struct.pack("<f", 500.0))
            c.call(DRIVE, drive(0.25, 0.0))
            t0 = time.monotonic()
            while time.monotonic() - t0 < 0.6:
                c.call(DRIVE, drive(0.25, 0.0))
                time.sleep(0.05)
            who = rng.choice(["observer", "controller", "burst", "ungreeted"])
            delay = rng.uniform(0, 0.05)
            sender = c if who in ("controller", "burst") else obs
            if who == "ungreeted":
                sender = Conn(d.port)
            d.signal(signal.SIGTERM)
            time.sleep(delay)
            if who == "burst":
                f1, _ = c.req(DRIVE, drive(0.25, 0.0))
                f2, rid = c.req(ESTOP)
                f3, _ = c.req(DRIVE, drive(0.25, 0.0))
                c.send(f1 + f2 + f3)
            else:
                rid = sender.cmd(ESTOP)
            m = sender.reply(rid, 3)
            obs.poll(0.5)
            tel = obs.telems()
            # velocity after the estop's ack: did the wheels stop at once (e-stop) or roll?
            tack = m.t if m else None
            roll = 0.0
            if tack is not None:
                after = [t for t in obs.log if t.type == TELEM and t.t >= tack]
                if len(after) >= 2:
                    a, b = parse_telem(after[0].p), parse_telem(after[-1].p)
                    roll = abs(b["left_rad"] - a["left_rad"]) * 0.1
            rc = d.p.wait(15)
            say("trial %d: SIGTERM, %s EmergencyStop %.1f ms later -> %s; rolled %.4f m after the "
                "Ack (telemetry frames after: %d); exit %s" % (
                    trial, who, delay * 1e3, m, roll,
                    len([t for t in obs.log if tack and t.type == TELEM and t.t >= tack]), rc))
            if not ok(m):
                fails.append("trial %d: EmergencyStop during shutdown not acked: %r" % (trial, m))
            st, _ = restart_check(d, trial)
            if ok(m) and st["fault"] != 13 + 500:
                say("  note: fault after restart is %d, not EMERGENCY_STOPPED" % st["fault"])
        elif mode == "reject":
            c.call(DRIVE, drive(0.2, 0.0))
            time.sleep(0.2)
            m = c.call(ESTOP)
            time.sleep(rng.uniform(0, 0.2))
            d.stop()
            say("trial %d: estop %s; SIGTERM; restart with door_width_m [1.0, 1.5]" % (trial, m))
            restart_check(d, trial, {"door_width_m": "[1.0, 1.5]"})
            d.stop()
            d.start()
            continue
        c.close()
finally:
    d.stop()
say("RESULT mode=%s seed=%d trials=%d fails=%d" % (mode, seed, trials, len(fails)))
for f in fails:
    say("  ", f)
