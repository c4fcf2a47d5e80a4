#!/usr/bin/env python3
"""Attack 4 (card), targeted: velocity commands accepted and not applied (GT_Update or GT_SetVel
dropped) at a jog's start from rest and at its release (Drive{0,0} while rolling at 0.2 m/s).
Expected: VELOCITY_MISMATCH (or MOTION_TIMEOUT) latched, emergency stop, wheels at rest.
Usage: card_release_miss.py [trials] [seed]"""
import glob, os, random, struct, subprocess, sys, time
from ajarwire import *
from simctl import SimCtl
trials = int(sys.argv[1]) if len(sys.argv) > 1 else 6
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed); rng = random.Random(seed)
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="relmiss")
fails = 0
d.start()
try:
    for t in range(trials):
        fn = rng.choice(["GT_Update", "GT_SetVel"])
        when = rng.choice(["start", "release"])
        c = d.conn(0, take_over=True); obs = d.conn(1); obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
        c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x01"); measure_all(c, plane=False)
        if when == "release":
            t0 = time.monotonic()
            while time.monotonic() - t0 < 1.0: c.call(DRIVE, drive(0.2, 0)); c.poll(0.03); obs.poll(0.02)
        ctl("FAIL %s 0 -1" % fn); tinj = time.monotonic()
        if when == "start":
            while time.monotonic() - tinj < 1.5: c.call(DRIVE, drive(0.2, 0)); c.poll(0.03); obs.poll(0.02)
        else:
            c.call(DRIVE, drive(0, 0))
            while time.monotonic() - tinj < 3.0: c.call(PING, b"\0"*8); c.poll(0.03); obs.poll(0.02)
        obs.poll(0.05)
        st = obs.status()
        tel = [(m.t - tinj, parse_telem(m.p)) for m in obs.log if m.type == TELEM]
        last = [x for _, x in tel[-10:]]
        rest = len({(x["left_counts"], x["right_counts"]) for x in last}) == 1
        # when did the wheels come to rest (counts constant from then on)?
        t_rest = None
        for i in range(len(tel) - 1, 0, -1):
            if (tel[i][1]["left_counts"], tel[i][1]["right_counts"]) != (tel[i-1][1]["left_counts"], tel[i-1][1]["right_counts"]):
                t_rest = tel[i][0]; break
        travel = max(abs(x["left_rad"]) for _, x in tel if _ > 0) * 0.1 if tel else 0
        evs = [(e[0], e[2], e[3][:70]) for e in obs.events() if e[0] in ("fault_latched",)]
        ev_t = [(round(m.t - tinj, 3), parse_event(m.p)[0]) for m in obs.log if m.type == EVENT]
        prev = None; chg = []
        for tt, x in tel:
            k = (x["left_counts"], x["right_counts"])
            if prev is not None and k != prev: chg.append(round(tt, 2))
            prev = k
        say("   events", ev_t, "count changes after inj: n=%d first..last %s" % (len([q for q in chg if q>0]), [q for q in chg if q > 0][-5:]))
        sp = [(round(tt,2), x["moving"], round(x["left_rad"],4)) for tt, x in tel if tt > 0][::25]
        say("   samples", sp)
        ctl("FAIL %s 0 0" % fn)
        good = st["fault"] != 0 and rest
        fails += not good
        say("%s trial %d %s dropped at jog %s: fault=%d %s; wheels last moved %.2f s after the injection; rest=%s" % (
            "OK  " if good else "FAIL", t, fn, when, st["fault"], evs[:2], t_rest if t_rest is not None else -1, rest))
        c.close(); obs.close()
finally:
    d.stop()
say("RESULT seed=%d fails=%d" % (seed, fails))
