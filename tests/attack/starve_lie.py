#!/usr/bin/env python3
"""A lying card after (or during) a starvation of the control loop (root; wave 13): the velocity
check's ramp model now runs over the whole gap (A4 fix), so a card that really does not follow
must still latch VELOCITY_MISMATCH within about velocity_mismatch_s once the loop runs again.

Usage: starve_lie.py [trials] [seed]      (env TIMEOUT=0.1, LOOPCPU=1; gcc needed)
HOGSCALE=0: the same seed's trials with hogs of 0 s (the baseline: the lie without starvation).
Each trial: jog +0.1 m/s for 1.5 s (card at speed), then one of
  ignore-reversal  GT_SetVel accepted and not applied (simctl "FAIL GT_SetVel 0 -1"), the operator
                   reverses to -0.1 m/s: the card keeps +0.1
  run-on-zero      the same, the operator lets go (Drive 0,0): the card keeps +0.1
  wrong-reverse    GT_SetVel applied negated (wrongway_preload.c), the operator reverses: the card
                   keeps going forward (told -x, runs +x)
  wrong-start      from rest, GT_SetVel negated, the operator jogs +0.1: the card runs backwards
  honest-reverse   control: no lie, the operator reverses (A4: no fault expected)
combined with a SCHED_FIFO hog of 0.2-0.6 s (below the 0.75 s cap) on the loop's CPU, the lie and
the operator's new command placed before / during / 0-200 ms after the hog. Prints per trial the
fault (journal + event) and its delay after the loop could act (max(command, hog end)); MISS: no
fault in 3 s; LATE: later than 0.6 s. Last line `RESULT ...`.
"""
import os
import random
import subprocess
import sys
import time

import starve_stall as ss
from ajarwire import *
from simctl import SimCtl

TRIALS = int(sys.argv[1]) if len(sys.argv) > 1 else 10
SEED = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
TIMEOUT = float(os.environ.get("TIMEOUT", "0.1"))
HOGSCALE = float(os.environ.get("HOGSCALE", "1"))  # 0: the same trials without a starvation
rng = random.Random(SEED)
KINDS = ["ignore-reversal", "run-on-zero", "wrong-reverse", "wrong-start", "honest-reverse"]
say("seed %d trials %d timeout %.3f (loadavg %s)" % (SEED, TRIALS, TIMEOUT, ss.loadavg()))

ctl = SimCtl()
so = "/tmp/ajar-attack4-wrongway.so"
subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-o", so,
                os.path.join(ss.HERE, "wrongway_preload.c"), "-ldl"], check=True)
flag = "/tmp/ajar-attack4-wrongway-%d" % os.getpid()
env = dict(ctl.env)
env["LD_PRELOAD"] = ctl.env["LD_PRELOAD"] + " " + so
env["AJAR_WRONGWAY_FILE"] = flag
o = dict(ctl.overrides)
o["stall_timeout_s"] = TIMEOUT
d = Daemon(o, env=env, name="starvelie")
d.start()
tail = ss.LogTail(d)
loop, ts = ss.pin(d.p.pid)
hog = ss.Hog(ss.LOOPCPU, "fifo", 50)
c = d.conn(0, take_over=True)
c.call(STOP)
time.sleep(0.3)
c.call(RESET, b"\x01")
measure_all(c, plane=False)
fails, rows = [], []


def clear():
    ctl("FAIL GT_SetVel 0 0")
    if os.path.exists(flag):
        os.unlink(flag)


def feed(v, until, seen, stop_on_fault=False):
    """Drive(v) every 40 ms until `until`; the first fault_latched event's time goes in seen."""
    while time.monotonic() < until and not (stop_on_fault and seen):
        c.call(DRIVE, drive(v, 0.0), timeout=2)
        for e in c.events():
            if e[0] == "fault_latched" and not seen:
                name = {520: "VELOCITY_MISMATCH", 517: "LOOP_STALLED", 512: "DEADMAN"}.get(
                    e[2], str(e[2]))
                seen.append((time.monotonic(), "%s %s" % (name, e[3])))
        c.log.clear()
        time.sleep(0.04)


try:
    for trial in range(TRIALS):
        kind = rng.choice(KINDS)
        where = rng.choice(["before", "during", "after"])
        dur = rng.uniform(0.2, 0.6) * HOGSCALE
        clear()
        ss.stop_then_reset(c, 0.4)
        c.log.clear()
        seen = []
        sign = rng.choice([1, -1])  # both ways: the base does not drift into the door guard
        v0 = 0.0 if kind == "wrong-start" else 0.1 * sign
        if v0:
            feed(v0, time.monotonic() + 1.5, seen)
        else:
            time.sleep(0.5)
        v1 = sign * {"ignore-reversal": -0.1, "run-on-zero": 0.0, "wrong-reverse": -0.1,
                     "wrong-start": 0.1, "honest-reverse": -0.1}[kind]
        if seen:
            say("SKIP trial %d: a fault before the lie: %s" % (trial, seen[0][1][:90]))
            continue
        n_lines = len(tail.lines)

        def lie():
            if kind in ("ignore-reversal", "run-on-zero"):
                ctl("FAIL GT_SetVel 0 -1")
            elif kind.startswith("wrong"):
                open(flag, "w").close()

        offset = rng.uniform(0.0, 0.1) if where == "before" else (
            rng.uniform(0.05, dur - 0.05) if where == "during" else rng.uniform(0.0, 0.2))
        if where == "before":
            lie()
            t_cmd = time.monotonic()
            feed(v1, t_cmd + offset, seen)
            hog.spin(dur)
            feed(v1, time.monotonic() + dur + 0.01, seen)
        elif where == "during":
            hog.spin(dur)
            feed(v0, time.monotonic() + offset, seen)
            lie()
            t_cmd = time.monotonic()
            feed(v1, t_cmd + dur - offset + 0.01, seen)
        else:  # after
            hog.spin(dur)
            feed(v0, time.monotonic() + dur + 0.01, seen)
        h0, h1 = hog.done()
        if where == "after":
            feed(v0, h1 + offset, seen)
            lie()
            t_cmd = time.monotonic()
        t_eff = max(t_cmd, h1)
        feed(v1, max(time.monotonic(), t_eff) + 3.0, seen, stop_on_fault=True)
        time.sleep(0.1)
        tail.poll()
        jl = [(t, l) for (t, l) in tail.lines[n_lines:] if "latched" in l or "VELOCITY" in l
              or "supervisor" in l]
        stalled = [l for (t, l) in jl if ss.LATCH_LINE in l]
        st = c.status()
        fault = seen[0] if seen else None
        delay = (fault[0] - t_eff) if fault else None
        delay_cmd = (fault[0] - t_cmd) if fault else None
        probs = []
        if kind == "honest-reverse":
            if fault:
                probs.append("false fault")
        else:
            if not fault:
                probs.append("MISS")
            elif "VELOCITY_MISMATCH" not in fault[1] and "FOLLOWING" not in fault[1]:
                probs.append("other fault")
            elif delay > 0.6:
                probs.append("LATE")
        if stalled:
            probs.append("LOOP_STALLED below the cap")
        rows.append((kind, where, delay))
        line = ("trial %d %s (sign %+d) lie %s the hog (hog %.2f s, cmd %+.0f ms from the hog's start, loop "
                "free %+.0f ms after the cmd): fault %s, %s after the loop could act; fault_code "
                "%s; %s after the cmd; journal %s; loadavg %s" % (
                    trial, kind, sign, where, dur, (t_cmd - h0) * 1e3, (h1 - t_cmd) * 1e3,
                    fault[1][:90] if fault else None,
                    "%.0f ms" % (delay * 1e3) if fault else "-", st["fault"] if st else None,
                    "%.0f ms" % (delay_cmd * 1e3) if fault else "-",
                    [l.strip()[-150:] for (t, l) in jl][:3], ss.loadavg()))
        say(("OK   " if not probs else "FAIL ") + line + (" :: %s" % probs if probs else ""))
        if probs:
            fails.append(line)
finally:
    clear()
    try:
        c.call(STOP)
    except Exception:
        pass
    hog.close()
    tail.stop = True
    rc = d.stop()
for k in KINDS:
    ds = sorted(r[2] * 1e3 for r in rows if r[0] == k and r[2] is not None)
    say("  %-16s %d trials, faults %d, delay ms %s" % (
        k, sum(1 for r in rows if r[0] == k), len(ds), ["%.0f" % x for x in ds]))
say("RESULT seed=%d trials=%d fails=%d rc=%s loadavg %s" % (SEED, TRIALS, len(fails), rc,
                                                              ss.loadavg()))
