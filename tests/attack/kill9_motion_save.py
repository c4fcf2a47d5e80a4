#!/usr/bin/env python3
"""Attack 1: kill -9 at random instants of AlignBase, Approach, a Drive jog, and during a state
save (measurements pipelined in one write, the kill 0..15 ms after it). Restart on the same state
directory and check: UNCLEAN_SHUTDOWN latched; every acked measurement restored byte for byte (an
unacked one either absent or whole); AlignBase/Approach/Drive refused; no wheel travel; then a
Reset (keeping the parameters) makes a Drive possible again, with the measurements still there.

Usage: kill9_motion_save.py [trials] [seed]
"""
import random
import struct
import sys
import time

from ajarwire import *

trials = int(sys.argv[1]) if len(sys.argv) > 1 else 10
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
fails = []

WB, HB, PB = slice(8, 65), slice(66, 123), slice(124, 205)


def jitter_points():
    dx = rng.uniform(-0.05, 0.05)
    w = pt(1.0 + dx, 0.45 + rng.uniform(-0.02, 0.02), 0.9) + pt(1.0 + dx, -0.45, 0.9)
    h = pt(1.0 + dx, -0.30, 0.9 + rng.uniform(-0.01, 0.01)) + pt(1.0 + dx, -0.40, 0.9)
    return w, h


def moved(tel):
    if len(tel) < 2:
        return 0.0
    lw = [t["left_rad"] for t in tel]
    rw = [t["right_rad"] for t in tel]
    return max(max(lw) - min(lw), max(rw) - min(rw)) * 0.1


d = Daemon({"drivers.kind": "sim"}, name="k9ms")
try:
    d.start()
    for trial in range(trials):
        kind = rng.choice(["align", "approach", "jog", "save", "save"])
        c = d.conn(0, take_over=True)
        r = c.call(RESET, b"\x01")
        acked = {}  # slice -> bytes acked
        sent = {}
        wpts, hpts = jitter_points()
        if kind == "save":
            planep = plane_pts(rng.uniform(-0.2, 0.2))
            f1, r1 = c.req(WIDTH, wpts)
            f2, r2 = c.req(HANDLE, hpts)
            f3, r3 = c.req(PLANE, planep)
            c.send(f1 + f2 + f3)
            delay = rng.uniform(0, 0.015)
            time.sleep(delay)
            c.poll(0)
            d.kill9()
            c.poll(0.05)
            for rid, sl, n in ((r1, WB, 57), (r2, HB, 57), (r3, PB, 81)):
                m = next((m for m in c.log if m.rid == rid and m.type in (ACK, ERROR)), None)
                if ok(m):
                    acked[(sl.start, sl.stop)] = m.p[3:3 + n]
            what = "save: 3 measurements in one write, SIGKILL %.2f ms after; acked %d" % (
                delay * 1e3, len(acked))
        else:
            for pts, mt, sl in ((wpts, WIDTH, WB), (hpts, HANDLE, HB)):
                m = c.call(mt, pts)
                assert ok(m), m
                acked[(sl.start, sl.stop)] = m.p[3:60]
            if kind == "align":
                m = c.call(PLANE, plane_pts(rng.choice([-1, 1]) * rng.uniform(0.1, 0.3)))
                assert ok(m), m
                rm = c.call(ALIGN)
            elif kind == "approach":
                rm = c.call(APPROACH, struct.pack("<d", rng.uniform(0.5, 0.8)))
            else:
                rm = c.call(DRIVE, drive(rng.uniform(-0.3, 0.3), rng.uniform(-0.5, 0.5)))
            delay = rng.uniform(0, 1.5)
            t0 = time.monotonic()
            while time.monotonic() - t0 < delay:
                if kind == "jog":
                    c.cmd(DRIVE, drive(0.2, 0.1))
                else:
                    c.cmd(PING, struct.pack("<Q", 0))
                time.sleep(0.03)
            c.poll(0)
            d.kill9()
            what = "%s (%s), SIGKILL %.3f s in" % (kind, describe(rm) if rm else None, delay)
        c.close()
        # restart
        d.start()
        c = d.conn(0)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 200.0))
        sm = c.call(STATUS)
        st = parse_status(sm.p)
        probs = []
        if st["fault"] != 519:
            probs.append("fault %d, not UNCLEAN_SHUTDOWN" % st["fault"])
        for (a, b), body in acked.items():
            if sm.p[a - 1] != 1 or sm.p[a:b] != body:
                probs.append("acked measurement at %d lost/changed (has=%d)" % (a, sm.p[a - 1]))
        rs = [c.call(DRIVE, drive(0.2, 0.0)), c.call(APPROACH, struct.pack("<d", 0.6)),
              c.call(ALIGN)]
        for x in rs:
            if ok(x):
                probs.append("accepted before Reset: %r" % x)
        time.sleep(0.5)
        obs.poll(0.05)
        tr = moved(obs.telems())
        if tr > 1e-4:
            probs.append("travel %.4f m after restart" % tr)
        if "rejected" in d.log().lower():
            probs.append("log mentions rejected state")
        # Reset keeps parameters; a Drive then works
        rr = c.call(RESET, b"\x00")
        sm2 = c.call(STATUS)
        for (a, b), body in acked.items():
            if sm2.p[a:b] != body:
                probs.append("measurement at %d changed by Reset" % a)
        dr = c.call(DRIVE, drive(0.1, 0.0))
        time.sleep(0.2)
        c.call(STOP)
        if not ok(rr) or not ok(dr):
            probs.append("after Reset: %r, Drive %r" % (rr, dr))
        errs = [describe(x) for x in rs]
        line = "trial %d %s -> restart state=%s fault=%d; refusals %s; travel %.5f" % (
            trial, what, st["state"], st["fault"], errs, tr)
        say(("OK   " if not probs else "FAIL ") + line + ("" if not probs else " :: %s" % probs))
        if probs:
            fails.append(line + " :: %s" % probs)
        c.close()
        obs.close()
        time.sleep(0.3)
finally:
    d.stop()
say("RESULT seed=%d trials=%d fails=%d" % (seed, trials, len(fails)))
