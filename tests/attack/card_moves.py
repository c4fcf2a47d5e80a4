#!/usr/bin/env python3
"""Attack 4 (card), the move paths of supervise_running / finish_move_at_rest / supervise_stopping:
  nostart     GT_Update accepted-not-applied before AlignBase / Approach: the move never starts
  lag         the encoders lag the profile by LAG ms (stale positions) during AlignBase / Approach / jog
  stopnoread  Stop mid-move, then GT_GetSts fails for N cycles (the card silent while stopping)
Prints fault, timeline (s after the command) of the closing event and the wheels' rest.
Usage: card_moves.py [trials] [seed]"""
import glob, os, random, struct, sys, time
from ajarwire import *
from simctl import SimCtl
trials = int(sys.argv[1]) if len(sys.argv) > 1 else 8
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed); rng = random.Random(seed)
ctl = SimCtl()
d = Daemon(ctl.overrides, env=ctl.env, name="cardmoves")
fails = 0
d.start()
try:
    for t in range(trials):
        case = rng.choice(["nostart", "lag", "stopnoread"])
        motion = rng.choice(["align", "approach"] + (["jog"] if case == "lag" else []))
        c = d.conn(0, take_over=True); obs = d.conn(1); obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
        c.call(STOP); time.sleep(0.5); c.call(RESET, b"\x01")
        ms = measure_all(c, plane=(motion == "align"), yaw_slope=rng.choice([-0.25, 0.25]))
        lag = rng.choice([50, 150, 400, 1000])
        n = rng.randint(5, 400)
        if case == "nostart": ctl("FAIL GT_Update 0 -1")
        if case == "lag": ctl("LAG %d" % lag)
        t0 = time.monotonic()
        m = c.call(ALIGN) if motion == "align" else c.call(APPROACH, struct.pack("<d", 0.5)) if motion == "approach" else c.call(DRIVE, drive(0.2, 0.2))
        stopped_at = None
        while time.monotonic() - t0 < (12.0 if case == "nostart" else 8.0):  # Approach: deadline ~9.5 s
            if motion == "jog" and time.monotonic() - t0 < 1.0: c.cmd(DRIVE, drive(0.2, 0.2))
            else: c.cmd(PING, b"\0"*8)
            c.poll(0.03); obs.poll(0.02)
            if case == "stopnoread" and stopped_at is None and time.monotonic() - t0 > 0.4:
                c.cmd(STOP); ctl("FAIL GT_GetSts -1 %d" % n); stopped_at = time.monotonic() - t0
            ev = [parse_event(x.p) for x in obs.log if x.type == EVENT]
            if any(e[0] in ("motion_finished", "motion_stopped") for e in ev) and time.monotonic() - t0 > 2.5: break
        ctl("FAIL GT_Update 0 0"); ctl("FAIL GT_GetSts 0 0"); ctl("LAG 1")
        obs.poll(0.3)
        st = obs.status()
        evt = [(round(x.t - t0, 2), parse_event(x.p)[0], parse_event(x.p)[2], parse_event(x.p)[3][:60]) for x in obs.log if x.type == EVENT and parse_event(x.p)[0] != "state_changed"]
        tel = [parse_telem(x.p) for x in obs.log if x.type == TELEM]
        rest = len({(x["left_counts"], x["right_counts"]) for x in tel[-10:]}) == 1
        o = sum(1 for e in evt if e[1] == "motion_started"); cl = sum(1 for e in evt if e[1] in ("motion_finished", "motion_stopped"))
        good = rest and o == cl and (case == "lag" or st["fault"] != 0)
        fails += not good
        say("%s trial %d %s%s during %s (%s): fault=%d rest=%s motions %d/%d; events %s" % (
            "OK  " if good else "FAIL", t, case, "(%d ms)" % lag if case == "lag" else "(n=%d, Stop at %.2f)" % (n, stopped_at or -1) if case == "stopnoread" else "",
            motion, describe(m) if m else None, st["fault"], rest, o, cl, evt[1:6]))
        c.close(); obs.close()
finally:
    d.stop()
say("RESULT seed=%d fails=%d" % (seed, fails))
