#!/usr/bin/env python3
"""Attack 5 (more orderings; races.py has the first ones): against a running ajard on sim.

 h) stops during a stop: Stop, then in one write Drive+Stop+EmergencyStop+Drive while the smooth
    stop runs; every motion_started closed exactly once, at rest, EMERGENCY_STOPPED latched
 i) bad frames around a Stop in one write while jogging: [Drive][Stop][bad magic] (the Stop before
    the framing error executes, the connection closes), [bad-CRC Stop] (not executed: CRC_MISMATCH,
    the jog keeps going until the same request id is re-sent), [oversize header] alone
 j) the controller's connection drops mid-Approach and the host reconnects with the same
    instance id and re-sends its Approach (same request id): the original reply, not executed again
 k) a Drive 0..20 ms after an acked Stop (separate writes): refused while the wheels stop, or a new
    jog; the Stop is never undone silently (the wheels decelerate after the Stop's Ack)
 l) a Stop trickled one byte per 5 ms during a jog (the operator's link is slow)
 m) duplicate Stop/EmergencyStop frames (same request id) in one write: each acked, latched once

Usage: races2.py [seed] [rounds]
"""
import struct
import sys
import time

from ajarwire import *

campaign = Campaign("races2", 4, echo_ok=True)
seed, rounds, rng, d = campaign.seed, campaign.rounds, campaign.rng, campaign.daemon
fails, verdict = campaign.fails, campaign.verdict


def fresh(instance=0):
    c = d.conn(0, take_over=True, instance=instance)
    c.call(STOP)
    t = time.monotonic()
    while time.monotonic() - t < 0.6:
        c.call(PING, b"\0" * 8)
        c.poll(0.05)
    r = c.call(RESET, b"\x01")
    assert ok(r), r
    measure_all(c, plane=False)
    return c


def jog(c, obs, secs=0.5, v=0.2, w=0.0):
    t = time.monotonic()
    while time.monotonic() - t < secs:
        c.call(DRIVE, drive(v, w))
        obs.poll(0.04)


def feed(c, obs, secs):
    t = time.monotonic()
    while time.monotonic() - t < secs:
        if not c.closed:
            try:
                c.cmd(PING, b"\0" * 8)
            except OSError:
                pass
            c.poll(0.02)
        obs.poll(0.03)


def wheel_speed(obs, since_ns, upto_ns=None):
    """max |wheel speed| (m/s at the rim) over telemetry in [since, upto]"""
    tel = [parse_telem(m.p) for m in obs.log if m.type == TELEM]
    tel = [t for t in tel if t["t_ns"] >= since_ns and (upto_ns is None or t["t_ns"] <= upto_ns)]
    vmax = 0.0
    for a, b in zip(tel, tel[1:]):
        dt = (b["t_ns"] - a["t_ns"]) * 1e-9
        if dt > 0:
            vmax = max(vmax, abs(b["left_rad"] - a["left_rad"]) * 0.1 / dt,
                       abs(b["right_rad"] - a["right_rad"]) * 0.1 / dt)
    return vmax, tel


def last_tns(obs):
    tel = [parse_telem(m.p) for m in obs.log if m.type == TELEM]
    return tel[-1]["t_ns"] if tel else 0


def balanced(obs):
    ev = [parse_event(m.p) for m in obs.log if m.type == EVENT]
    o = sum(1 for e in ev if e[0] == "motion_started")
    cl = sum(1 for e in ev if e[0] in ("motion_finished", "motion_stopped"))
    return o, cl


obs = d.conn(1)
obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
try:
    for r in range(rounds):
        # h) stops during a stop
        obs.log.clear()
        c = fresh()
        jog(c, obs, 0.6, 0.3)
        s1 = c.call(STOP)
        time.sleep(rng.uniform(0, 0.1))
        f1, r1 = c.req(DRIVE, drive(0.3, 0))
        f2, r2 = c.req(STOP)
        f3, r3 = c.req(ESTOP)
        f4, r4 = c.req(DRIVE, drive(0.3, 0))
        c.send(f1 + f2 + f3 + f4)
        reps = [c.reply(x, 3) for x in (r1, r2, r3, r4)]
        feed(c, obs, 1.5)
        st = obs.status()
        v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
        o, cl = balanced(obs)
        verdict("h stops during a stop", ok(s1) and ok(reps[1]) and ok(reps[2]) and not ok(reps[3])
                and st["fault"] == 513 and v < 1e-4 and o == cl,
                "replies %s; fault %d; speed in last 0.5 s %.4f; motions %d/%d" % (
                    [describe(x) if x else None for x in reps], st["fault"], v, o, cl))
        c.close()

        # i) bad frames around a Stop
        for variant in ("stop+badmagic", "badcrc-stop", "oversize"):
            obs.log.clear()
            c = fresh()
            jog(c, obs, 0.5)
            fd, rd = c.req(DRIVE, drive(0.2, 0))
            fs, rs = c.req(STOP)
            t_send = last_tns(obs)
            if variant == "stop+badmagic":
                c.send(fd + fs + b"XJAR" + fs[4:])
                m = c.reply(rs, 3)
                feed(c, obs, 1.5)
                v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
                st = obs.status()
                good = ok(m) and v < 1e-4
                detail = "Stop %s; closed=%s; fault %d; speed last 0.5 s %.4f" % (
                    describe(m) if m else None, c.closed, st["fault"], v)
            elif variant == "badcrc-stop":
                bad = frame(STOP, b"", rs, corrupt_crc=True)
                c.send(bad)
                m = c.reply(rs, 1)
                feed(c, obs, 0.3)  # pings only: the jog's own timeout (0.5 s) ends it anyway
                v1, _ = wheel_speed(obs, t_send)
                n0 = len(c.log)
                c.send(fs)  # re-sent, same id
                c.wait(lambda x: x.rid == rs and x.type in (ACK, ERROR) and c.log.index(x) >= n0, 2)
                m2 = next((x for x in c.log[n0:] if x.rid == rs and x.type in (ACK, ERROR)), None)
                feed(c, obs, 1.2)
                v2, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
                good = (m is not None and err(m) == 103) and ok(m2) and v2 < 1e-4
                detail = "bad-CRC Stop -> %s; re-sent -> %s; speed last 0.5 s %.4f" % (
                    describe(m) if m else None, describe(m2) if m2 else None, v2)
            else:
                hdr = struct.pack("<IBBHHII", 0x52414A41, 1, 1, STOP, 0, 999, 1 << 20)
                c.send(hdr + struct.pack("<I", crc32c(hdr)))
                feed(c, obs, 1.8)
                st = obs.status()
                v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
                errs = [describe(x) for x in c.log if x.type == ERROR]
                good = c.closed and v < 1e-4 and st["fault"] == 512
                detail = "closed=%s errors %s; fault %d; speed last 0.5 s %.4f" % (
                    c.closed, errs[-1:], st["fault"], v)
            o, cl = balanced(obs)
            verdict("i " + variant, good and o == cl, detail + "; motions %d/%d" % (o, cl))
            c.close()

        # j) reconnect mid-Approach, same instance id, re-sent Approach
        obs.log.clear()
        inst = 0x5EED0000 + r
        c = fresh(instance=inst)
        fa, ra = c.req(APPROACH, struct.pack("<d", 0.6))
        c.send(fa)
        a1 = c.reply(ra, 3)
        feed(c, obs, rng.uniform(0.05, 0.4))
        c.close()
        c2 = d.conn(None)
        c2.greet(0, take_over=True, instance=inst)
        c2.send(frame(APPROACH, struct.pack("<d", 0.6), ra, flags=1))
        a2 = c2.reply(ra, 3)
        feed(c2, obs, 2.0)
        st = obs.status()
        starts = [e for e in obs.events() if e[0] == "motion_started"]
        v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
        o, cl = balanced(obs)
        verdict("j reconnect + re-sent Approach executes once",
                ok(a1) and len(starts) == 1 and v < 1e-4 and o == cl,
                "first %s, re-sent %s; starts %d; fault %d; speed last 0.5 s %.4f; motions %d/%d" % (
                    describe(a1) if a1 else None, describe(a2) if a2 else None, len(starts),
                    st["fault"], v, o, cl))
        c2.close()

        # k) Drive right after an acked Stop
        obs.log.clear()
        c = fresh()
        jog(c, obs, 0.6, 0.3)
        s = c.call(STOP)
        time.sleep(rng.uniform(0, 0.02))
        dm = c.call(DRIVE, drive(0.3, 0))
        feed(c, obs, 0.05)
        c.call(DRIVE, drive(0, 0)) if ok(dm) else None
        feed(c, obs, 1.5)
        v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
        o, cl = balanced(obs)
        verdict("k Drive after an acked Stop", ok(s) and v < 1e-4 and o == cl,
                "Stop %s, Drive %s; at rest %s; motions %d/%d" % (
                    describe(s) if s else None, describe(dm) if dm else None, v < 1e-4, o, cl))
        c.close()

        # l) trickled Stop
        obs.log.clear()
        c = fresh()
        jog(c, obs, 0.3)
        fs, rs = c.req(STOP)
        for i in range(len(fs)):
            c.send(fs[i:i + 1])
            c.cmd(PING, b"\0" * 8) if False else None
            obs.poll(0.005)
        m = c.reply(rs, 3)
        feed(c, obs, 1.2)
        v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
        st = obs.status()
        verdict("l trickled Stop", ok(m) and v < 1e-4, "Stop %s; fault %d; speed %.4f" % (
            describe(m) if m else None, st["fault"], v))
        c.close()

        # m) duplicate stops with one id
        obs.log.clear()
        c = fresh()
        jog(c, obs, 0.3)
        fs, rs = c.req(STOP)
        fe = frame(ESTOP, b"", rs)
        c.send(fs + fs + fe + fe + frame(STOP, b"", rs, flags=1))
        feed(c, obs, 1.2)
        reps = [describe(x) for x in c.log if x.rid == rs]
        st = obs.status()
        lat = [e for e in obs.events() if e[0] == "fault_latched"]
        v, _ = wheel_speed(obs, last_tns(obs) - int(0.5e9))
        verdict("m duplicate stops", st["fault"] == 513 and v < 1e-4 and len(lat) == 1,
                "replies %s; fault %d; latched events %d; speed %.4f" % (reps, st["fault"],
                                                                         len(lat), v))
        c.close()
        if d.p.poll() is not None:
            fails.append("ajard died")
            break
finally:
    rc = d.stop()
    say("ajard exit", rc)
campaign.report(50)
