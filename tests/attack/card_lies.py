#!/usr/bin/env python3
"""Attack 4 (card): the card simulator misbehaves mid-motion (jog, Approach, AlignBase): status or
position reads fail for N calls (missed updates), a drive alarm / following error / limit on one
axis, GT_SetVel or GT_Trap updates accepted and not applied, GT_Stop accepted and not applied.

Checks: a fault is latched (code printed, with the log line that names the axis), the wheels are at
rest within 1.5 s, Drive/Approach/AlignBase refused until Reset, and after the injection is cleared
a Reset makes the base drivable again.

Usage: card_lies.py [trials] [seed]      (LD_PRELOAD shim simctl_preload.c; gcc needed)
"""
import os
import random
import struct
import sys
import time

from ajarwire import *
from simctl import SimCtl

trials = int(sys.argv[1]) if len(sys.argv) > 1 else 12
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="cardlies")


FAULTS = ["read-sts", "read-enc", "read-prf", "alarm", "following", "limit", "setvel-miss",
          "update-miss", "stop-miss", "read-sts-long"]
MUST_LATCH = ("read-sts", "read-sts-long", "read-enc", "read-prf", "alarm", "following", "limit")
fails = []
try:
    d.start()
    for trial in range(trials):
        fault = rng.choice(FAULTS)
        motion = rng.choice(["jog", "approach", "align"])
        axis = rng.choice([1, 2])
        c = d.conn(0, take_over=True)
        c.call(STOP)
        time.sleep(0.3)
        c.call(RESET, b"\x01")
        measure_all(c, plane=(motion == "align"), yaw_slope=rng.choice([-0.25, 0.25]))
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
        if motion == "jog":
            m = c.call(DRIVE, drive(0.2, rng.uniform(-0.3, 0.3)))
        elif motion == "approach":
            m = c.call(APPROACH, struct.pack("<d", 0.5))
        else:
            m = c.call(ALIGN)
        delay = rng.uniform(0.05, 0.6)
        t0 = time.monotonic()
        while time.monotonic() - t0 < delay:
            c.cmd(DRIVE, drive(0.2, 0.0)) if motion == "jog" else c.cmd(PING, b"\0" * 8)
            c.poll(0.04)
        n = rng.randint(1, 40)
        if fault == "read-sts":
            ctl("FAIL GT_GetSts -1 %d" % n)
        elif fault == "read-sts-long":
            ctl("FAIL GT_GetSts -1 -1")
        elif fault == "read-enc":
            ctl("FAIL GT_GetEncPos -1 %d" % n)
        elif fault == "read-prf":
            ctl("FAIL GT_GetPrfPos -1 %d" % n)
        elif fault == "alarm":
            ctl("FAULT %d 1" % axis)
        elif fault == "following":
            ctl("FAULT %d 2" % axis)
        elif fault == "limit":
            ctl("FAULT %d %d" % (axis, rng.choice([3, 4])))
        elif fault == "setvel-miss":
            ctl("FAIL GT_SetVel 0 -1")
        elif fault == "update-miss":
            ctl("FAIL GT_Update 0 -1")
        elif fault == "stop-miss":
            ctl("FAIL GT_Stop 0 -1")
        tinj = time.monotonic()
        # keep feeding as an operator holding the key would (jog), then let go / Stop
        while time.monotonic() - tinj < 0.4:
            c.cmd(DRIVE, drive(0.2, 0.0)) if motion == "jog" else c.cmd(PING, b"\0" * 8)
            c.poll(0.04)
        if fault in ("setvel-miss", "update-miss", "stop-miss"):
            c.call(STOP)
        # watch 1.5 s
        tw = time.monotonic()
        while time.monotonic() - tw < 1.5:
            c.cmd(PING, b"\0" * 8)
            c.poll(0.05)
            obs.poll(0)
        st = obs.status()
        tel = obs.telems()
        last = tel[-15:]
        rest = len({(t["left_counts"], t["right_counts"]) for t in last}) == 1
        moving_flag = any(t["moving"] for t in last[-3:])
        refusals = [c.call(DRIVE, drive(0.2, 0)), c.call(APPROACH, struct.pack("<d", 0.6))]
        # clear the injection
        for fn in ("GT_GetSts", "GT_GetEncPos", "GT_GetPrfPos", "GT_SetVel", "GT_Update", "GT_Stop"):
            ctl("FAIL %s 0 0" % fn)  # (a "*" rule clears only "*" rules)
        ctl("FAULT 1 0")
        ctl("FAULT 2 0")
        c.call(STOP)  # a Drive accepted above (no fault latched) stops before the Reset
        feed_t = time.monotonic()
        while time.monotonic() - feed_t < 0.8:
            c.cmd(PING, b"\0" * 8)
            c.poll(0.05)
        rr = c.call(RESET, b"\x00")
        dr = c.call(DRIVE, drive(0.1, 0))
        time.sleep(0.3)
        c.call(STOP)
        evs = [(e[0], e[2], e[3][:80]) for e in obs.events() if e[0] == "fault_latched"]
        probs = []
        # must latch: a missed read, a drive fault; a dropped command may come too late to matter
        # (the motion had ended) or not concern the motion (GT_SetVel during a move)
        if st["fault"] == 0 and fault in MUST_LATCH:
            probs.append("no fault latched")
        if fault == "read-sts-long":  # the card never answers again: telemetry is its last answer
            if st["card"] != 3:
                probs.append("card shown %d, not fault, while it does not answer" % st["card"])
        elif not rest or moving_flag:
            probs.append("wheels not at rest 1.9 s after the injection (moving=%s)" % moving_flag)
        if st["fault"] != 0 and any(ok(x) for x in refusals):
            probs.append("accepted before Reset: %s" % refusals)
        if not ok(rr) or not ok(dr):
            probs.append("not drivable after clear+Reset: %r %r" % (rr, dr))
        line = "trial %d %s(n=%d axis=%d) during %s +%.2fs: fault=%d evs=%s; refusal=%s; reset=%s drive=%s" % (
            trial, fault, n, axis, motion, delay, st["fault"], evs[:2],
            describe(refusals[0]) if refusals[0] else None, describe(rr) if rr else None,
            describe(dr) if dr else None)
        say(("OK   " if not probs else "FAIL ") + line + (" :: %s" % probs if probs else ""))
        if probs:
            fails.append(line + " :: %s" % probs)
        c.close()
        obs.close()
finally:
    d.stop()
import re
say("journal lines with fault/axis (last 25):")
for l in [l for l in d.log().splitlines() if re.search(r"axis|latched|VELOCITY|COMMUNICATION|TIMEOUT", l)][-25:]:
    say("   ", l[:240])
say("RESULT seed=%d trials=%d fails=%d" % (seed, trials, len(fails)))
