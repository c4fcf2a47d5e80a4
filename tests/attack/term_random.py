#!/usr/bin/env python3
"""SIGTERM at random instants: mid-jog, mid-AlignBase, mid-Approach, with measurements in flight,
idle. An observer subscribed at 200 Hz watches the wheels until the connection closes.

Checks per trial: ajard exits 0 within 15 s; every motion_started was closed (motion_finished /
motion_stopped: the loop saw both axes at rest before the state was sealed — the base was commanded
to stop, not abandoned; the wheel speed in the last telemetry frames is printed); after
the restart nothing moves by itself (telemetry) and every measurement acknowledged before the
SIGTERM is restored.

Usage: term_random.py [trials] [seed]     (KIND=sim|mock, default sim)
"""
import os
import random
import signal
import struct
import sys
import time

from ajarwire import *

trials = int(sys.argv[1]) if len(sys.argv) > 1 else 10
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
kind = os.environ.get("KIND", "sim")
d = Daemon({"drivers.kind": kind}, name="termrandom")
fails = []


def fail(line):
    say("  FAIL " + line)
    fails.append(line)


try:
    d.start()
    for trial in range(trials):
        c = d.conn(0, take_over=True)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 200.0))
        c.call(STOP)
        c.call(RESET, b"\x01")
        what = rng.choice(["jog", "align", "approach", "measure", "idle"])
        acked = {}
        if what != "measure":
            for key, t, p in (("has_width", WIDTH, WIDTH_PTS), ("has_handle", HANDLE, HANDLE_PTS),
                              ("has_plane", PLANE, plane_pts(0.2))):
                acked[key] = ok(c.call(t, p))
        if what == "jog":
            c.call(DRIVE, drive(0.2, 0.3))
        elif what == "align":
            c.call(ALIGN)
        elif what == "approach":
            c.call(APPROACH, struct.pack("<d", 0.6))
        elif what == "measure":
            rids = [(k, c.cmd(t, p)) for k, t, p in (("has_width", WIDTH, WIDTH_PTS),
                                                       ("has_handle", HANDLE, HANDLE_PTS))]
        delay = rng.uniform(0.0, 0.6)
        t0 = time.monotonic()
        while time.monotonic() - t0 < delay:
            if what == "jog":
                c.cmd(DRIVE, drive(0.2, 0.3))
            else:
                c.cmd(PING, b"\0" * 8)
            c.poll(0.03)
        tterm = time.monotonic()
        d.signal(signal.SIGTERM)
        # Keep the deadman fed as a live operator would, until the daemon closes us.
        while not obs.closed and time.monotonic() - tterm < 20:
            try:
                c.cmd(PING, b"\0" * 8)
            except OSError:
                pass
            c.poll(0.02)
            obs.poll(0.02)
        try:
            rc = d.p.wait(15)
        except Exception:
            rc = None
        dt = time.monotonic() - tterm
        if what == "measure":
            for key, rid in rids:
                acked[key] = ok(next((x for x in c.log if x.rid == rid), None))
        # The daemon says the motion ended (its loop saw both axes at rest) before it exited: the
        # observer's events; and the wheel speed in the last telemetry frames is falling.
        tel = [(m.t, parse_telem(m.p)) for m in obs.log if m.type == TELEM]
        ev = [parse_event(m.p) for m in obs.log if m.type == EVENT]
        opened = sum(1 for e in ev if e[0] == "motion_started")
        closed = sum(1 for e in ev if e[0] in ("motion_finished", "motion_stopped"))

        def speed(a, b):
            dt_s = (b["t_ns"] - a["t_ns"]) * 1e-9
            return max(abs(b["left_counts"] - a["left_counts"]),
                       abs(b["right_counts"] - a["right_counts"])) / dt_s if dt_s > 0 else 0

        after = [t for mt, t in tel if mt >= tterm]
        v_term = speed(after[0], after[1]) if len(after) > 2 else 0
        v_end = speed(after[-2], after[-1]) if len(after) > 2 else 0
        rest = v_end <= max(v_term, 1.0) * 0.5 or v_end < 50
        line = "trial %d: %s, SIGTERM after %.3f s: exit %s in %.2f s; wheel speed %.0f -> %.0f " \
               "counts/s in the last frames; motions opened %d closed %d" % (
                   trial, what, delay, rc, dt, v_term, v_end, opened, closed)
        # (the speeds are shown, not judged: telemetry ends when the state is sealed, a few ms
        # before the wheels rest; the closing event is the daemon's word that they did)
        good = rc == 0 and dt < 15 and opened == closed
        # Restart: nothing moves; acknowledged measurements restored.
        d.start()
        c2 = d.conn(0, take_over=True)
        o2 = d.conn(1)
        o2.call(SUBSCRIBE, struct.pack("<f", 100.0))
        st = c2.status()
        o2.poll(0.4)
        t2 = o2.telems()
        moved = len({(t["left_counts"], t["right_counts"]) for t in t2}) > 1 or \
            any(t["moving"] for t in t2)
        lost = [k for k, v in acked.items() if v and not st[k]]
        line += "; restart fault=%d moved=%s lost=%s" % (st["fault"], moved, lost)
        good = good and not moved and not lost and st["fault"] != 519
        if good:
            say("  OK " + line)
        else:
            fail(line)
        for x in (c, obs, c2, o2):
            x.close()
    d.stop()
finally:
    if d.p and d.p.poll() is None:
        d.stop()
say("%d failures" % len(fails))
for f in fails:
    say("  " + f)
sys.exit(1 if fails else 0)
