#!/usr/bin/env python3
"""Item 9: hostile orderings on the wire against a running ajard (mock drivers, fast).

Usage: races.py [seed] [rounds]
Each check prints OK/FAIL with what it saw.
"""
import struct
import sys
import time

from ajarwire import *

campaign = Campaign("races", 5)
seed, rounds, rng, d = campaign.seed, campaign.rounds, campaign.rng, campaign.daemon
fails, verdict = campaign.fails, campaign.verdict


def fresh(instance=0):
    c = d.conn(0, take_over=True, instance=instance)
    c.call(STOP)
    c.wait(lambda m: False, 0.3)
    c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    return c


def rest_after(c, obs, t_from, settle=1.5):
    """Wheel travel in telemetry received after t_from + settle (must be ~0)."""
    obs.poll(settle + 0.6)
    tel = [parse_telem(m.p) for m in obs.log if m.type == TELEM and m.t > t_from + settle]
    if len(tel) < 2:
        return None
    return abs(tel[-1]["left_rad"] - tel[0]["left_rad"]) * 0.1


obs = d.conn(1)
obs.call(SUBSCRIBE, struct.pack("<f", 50.0))
try:
    for r in range(rounds):
        # a) Drive, Stop, Drive in one write while jogging: the Stop is acked; afterwards rest.
        c = fresh()
        for _ in range(3):
            c.call(DRIVE, drive(0.2, 0.0))
            obs.poll(0.1)
        f1, _ = c.req(DRIVE, drive(0.3, 0.2))
        f2, rs = c.req(STOP)
        f3, r3 = c.req(DRIVE, drive(0.3, 0.2))
        order = rng.choice(["DSD", "SD", "DS"])
        data = {"DSD": f1 + f2 + f3, "SD": f2 + f3, "DS": f1 + f2}[order]
        c.send(data)
        ms = c.reply(rs)
        m3 = c.reply(r3, 1) if "D" in order[1:] else None
        t = time.monotonic()
        for _ in range(20):  # keep the deadman fed
            c.call(PING, b"\0" * 8)
            obs.poll(0.1)
        tr = rest_after(c, obs, t, 1.0)
        verdict("a stop racing drives in one write", ok(ms) and tr is not None and tr < 1e-4,
                "order %s stop %s drive-after %s travel after 1 s %s" % (order, ms, m3, tr))
        # b) duplicate Approach (same rid, instance id set) executes once
        c = fresh(instance=0xA77AC0 + r)
        fa, ra = c.req(APPROACH, struct.pack("<d", 0.7))
        fb = frame(APPROACH, struct.pack("<d", 0.7), ra, flags=1)
        c.send(fa + fb + (fb if r % 2 else b""))
        c.reply(ra)
        c.wait(lambda m: False, 0.5)
        starts = [e for e in c.events() if e[0] == "motion_started"]
        verdict("b duplicate Approach executes once", len(starts) == 1, "starts %s" % starts)
        c.call(STOP)
        c.wait(lambda m: False, 1.0)
        # c) Reset retransmitted after an EmergencyStop must not clear it
        c = fresh(instance=0xBEEF00 + r)
        c.call(ESTOP)
        f, rr = c.req(RESET, b"\x00")
        c.send(f)
        c.reply(rr)
        c.call(ESTOP)
        c.send(frame(RESET, b"\x00", rr, flags=1))
        rep = c.reply(rr)
        st = c.status()
        verdict("c retransmitted Reset does not clear a later e-stop", st["fault"] == 513,
                "retransmit reply %s, status fault %d" % (rep, st["fault"]))
        # d) Reset then EmergencyStop in one write: latched afterwards
        c.send(frame(RESET, b"\x00", 7001 + r) + frame(ESTOP, b"", 7101 + r))
        c.reply(7101 + r)
        st = c.status()
        verdict("d Reset+EmergencyStop in one write: latched", st["fault"] == 513, "fault %d" %
                st["fault"])
        # e) take-over during a jog: stopped, DEADMAN latched; the old controller cannot drive
        c = fresh()
        for _ in range(5):
            c.call(DRIVE, drive(0.2, 0.0))
            obs.poll(0.05)
        b = Conn(d.port)
        b.greet(0, take_over=True)
        old = c.call(DRIVE, drive(0.2, 0.0))
        t = time.monotonic()
        tr = rest_after(c, obs, t, 1.0)
        st = b.status()
        verdict("e take-over mid-jog stops and latches", st["fault"] == 512 and err(old) == 202 and
                tr is not None and tr < 1e-4, "fault %d old-controller Drive %s travel %s" %
                (st["fault"], old, tr))
        b.close()
        # f) deadman: controller goes silent (socket open, like a SIGSTOPped client) mid-Approach
        c = fresh()
        a = c.call(APPROACH, struct.pack("<d", 0.5))
        t = time.monotonic()
        obs.poll(2.5)
        st = obs.status()
        tr = rest_after(c, obs, t, 1.8)
        verdict("f silent controller mid-Approach: DEADMAN", ok(a) and st["fault"] == 512 and
                tr is not None and tr < 1e-4, "approach %s fault %d travel %s" % (a, st["fault"], tr))
        c.close()
        # g) absurd values
        c = fresh()
        bad = []
        for v, w in ((1e308, 0), (-1e308, 1e308), (5e-324, 0), (0, -1e300), (3.0, 30.0)):
            m = c.call(DRIVE, drive(v, w))
            c.call(PING, b"\0" * 8)
            obs.poll(0.05)
            bad.append(("%g,%g" % (v, w), "ack" if ok(m) else err(m)))
        c.call(DRIVE, drive(0, 0))
        obs.poll(0.5)
        tel = [parse_telem(m.p) for m in obs.log if m.type == TELEM][-60:]
        vmax = max(abs(t["cmd_v"]) for t in tel) if tel else 0
        wmax = max(abs(t["cmd_w"]) for t in tel) if tel else 0
        for sd in (-1e9, 1e300, 0.0, 5e-324, -0.0):
            m = c.call(APPROACH, struct.pack("<d", sd))
            bad.append(("approach %g" % sd, "ack" if ok(m) else err(m)))
        for rate in (1e30, -1.0, 3.4e38):
            m = c.call(SUBSCRIBE, struct.pack("<f", rate))
            bad.append(("subscribe %g" % rate, "ack" if ok(m) else err(m)))
        c.call(SUBSCRIBE, struct.pack("<f", 0.0))
        verdict("g absurd values clamped", vmax <= 0.3 + 1e-9 and wmax <= 0.6 + 1e-9,
                "cmd max %.3f m/s %.3f rad/s; replies %s" % (vmax, wmax, bad))
        if r == 0:
            say("g replies:", bad, "cmd max", vmax, wmax)
        c.call(STOP)
        c.close()
        if d.p.poll() is not None:
            fails.append("ajard died")
            break
finally:
    d.stop()
campaign.report(55)
