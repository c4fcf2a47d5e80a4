#!/usr/bin/env python3
"""ajard frozen, killed or stopped while its control thread is starved or a stall is latched
(root; the helpers of starve_stall.py; config/ajard.yaml, stall_timeout_s 0.1).

Usage: pause_kill.py MODE [trials] [seed]
  pause          SIGSTOP of the whole ajard for 0.05-1.5 s at random instants of a back-and-forth
                 jog: no LOOP_STALLED expected (the supervisor was stopped too).
  kill9-starved  kill -9 while a SCHED_FIFO hog keeps ajar-loop off its CPU mid-jog (0.1-0.6 s
                 into it); restart: starts, UNCLEAN_SHUTDOWN latched, no travel, Drive refused.
  term-starved   SIGTERM there instead: exit 0 (docs/operations.md) once the hog ends; restart
                 clean (no fault), nothing moves.
  term-stalled   a card call hung (AJAR_SIM_BLOCK_FILE) and LOOP_STALLED latched, then SIGTERM:
                 exit 3 (docs/control-loop.md) within systemd's TimeoutStopSec=15 (measured
                 ~8 s: 5 s for the wheels, the save, 1 s for the control thread); restart:
                 LOOP_STALLED kept.
  kill9-stalled  the same with kill -9: restart with LOOP_STALLED (persisted at the latch) or
                 UNCLEAN_SHUTDOWN latched, nothing moves.
Prints the seed and per trial what happened; last line `RESULT ...`.
"""
import os
import random
import signal
import sys
import time

import starve_stall as S
from ajarwire import *

MODE = sys.argv[1]
TRIALS = int(sys.argv[2]) if len(sys.argv) > 2 else 4
SEED = int(sys.argv[3]) if len(sys.argv) > 3 else int(time.time())
rng = random.Random(SEED)
say("seed %d mode %s trials %d (loadavg %s)" % (SEED, MODE, TRIALS, S.loadavg()))


def jog(c, v=0.1, n=5):
    for _ in range(n):
        c.call(DRIVE, drive(v, 0.0))
        time.sleep(0.04)


def pause():
    d = S.daemon(0.1)
    tail = S.LogTail(d)
    j, obs = S.Jogger(d), S.Observer(d)
    for trial in range(TRIALS):
        time.sleep(rng.uniform(0.3, 1.5))
        p = rng.uniform(0.05, 1.5)
        d.signal(signal.SIGSTOP)
        time.sleep(p)
        d.signal(signal.SIGCONT)
        say("trial %d: SIGSTOP %.2f s" % (trial, p))
    time.sleep(1.0)
    j.close()
    obs.close()
    tail.poll()
    faults = [f[1] for f in j.faults]
    say("  latches %d; faults %s; loadavg %s" % (len(tail.latches), faults, S.loadavg()))
    for l in tail.latches:
        say("   ", l[3].strip())
    d.stop()
    return len(tail.latches) == 0, "LOOP_STALLED latched %d" % len(tail.latches)


def signal_and_wait(d, sig):
    """Sends sig; the exit status (None: still running 20 s later) and how long it took."""
    t0 = time.monotonic()
    d.signal(sig)
    try:
        rc = d.p.wait(20)
    except Exception:
        rc = None
    return rc, time.monotonic() - t0


def restart_check(d, expect):
    """After the exit: start again; the fault latched, no travel in 1 s, a Drive refused."""
    d.start()
    c = d.conn(0, take_over=True)
    s0 = c.status()
    jog(c, 0.1, 10)
    s1 = c.status()
    r = c.call(DRIVE, drive(0.1, 0.0))
    c.close()
    moved = abs(s1["odo_x"] - s0["odo_x"])
    good = s0["fault"] in expect and moved < 1e-4 and not ok(r)
    if not expect:  # clean: no fault, the jog works
        good = s0["fault"] == 0
    detail = "restart: fault %d, travel in 0.4 s of Drives %.4f m, Drive -> %s" % (
        s0["fault"], moved, describe(r) if r else None)
    d.stop()
    return good, detail


def kill_or_term_starved(sig):
    results = []
    for trial in range(TRIALS):
        d = S.daemon(0.1)
        loop, _ = S.pin(d.p.pid)
        hog = S.Hog(S.LOOPCPU, "fifo", 50)
        c = d.conn(0, take_over=True)
        c.call(RESET, b"\x01")
        measure_all(c, plane=False)
        jog(c)
        hold, at = rng.uniform(0.5, 0.9), rng.uniform(0.1, 0.4)
        hog.spin(hold)
        time.sleep(at)
        t0 = time.monotonic()
        rc, took = signal_and_wait(d, sig)
        h0, h1 = hog.done()
        hog.close()
        c.close()
        tail = open(d.logpath).read()
        latched = "made no cycle" in tail
        if sig == signal.SIGKILL:
            good, detail = restart_check(d, (519,))  # UNCLEAN_SHUTDOWN
            expect_rc = -9
        else:
            good, detail = restart_check(d, ())
            expect_rc = 0
        good = good and rc == expect_rc and not latched
        say("trial %d: %s %.0f ms into a %.2f s hog: exit %s after %.0f ms (hog ended %.0f ms "
            "after the signal); LOOP_STALLED in the journal: %s; %s%s" % (
                trial, "kill -9" if sig == signal.SIGKILL else "SIGTERM", at * 1e3, hold, rc,
                took * 1e3, (h1 - t0) * 1e3, latched, detail, "" if good else "  <-- FAIL"))
        results.append(good)
    return all(results), "%d/%d as expected" % (sum(results), len(results))


def kill_or_term_stalled(sig):
    results = []
    for trial in range(TRIALS):
        flag = "/tmp/ajar-attack3-pk-%d" % os.getpid()
        d = S.daemon(0.1, env={"AJAR_SIM_BLOCK_FILE": flag})
        tail = S.LogTail(d)
        c = d.conn(0, take_over=True)
        c.call(RESET, b"\x01")
        measure_all(c, plane=False)
        jog(c)
        open(flag, "w").close()
        end = time.monotonic() + 3
        while not tail.latches and time.monotonic() < end:
            time.sleep(0.01)
        time.sleep(rng.uniform(0.0, 0.5))
        t0 = time.monotonic()
        rc, took = signal_and_wait(d, sig)
        os.unlink(flag)
        tail.stop = True
        c.close()
        if rc is None:
            d.kill9()
        d.env.pop("AJAR_SIM_BLOCK_FILE", None)
        good, detail = restart_check(d, (517, 519) if sig == signal.SIGKILL else (517,))
        expect_rc = -9 if sig == signal.SIGKILL else 3
        good = good and rc == expect_rc and bool(tail.latches) and (
            sig == signal.SIGKILL or took < 15)  # TimeoutStopSec (5 s wheels, 5 s disk, ...)
        say("trial %d: stall latched %s; %s: exit %s after %.0f ms; %s%s" % (
            trial, bool(tail.latches), "kill -9" if sig == signal.SIGKILL else "SIGTERM", rc,
            took * 1e3, detail, "" if good else "  <-- FAIL"))
        results.append(good)
    return all(results), "%d/%d as expected" % (sum(results), len(results))


if MODE == "pause":
    good, text = pause()
elif MODE == "kill9-starved":
    good, text = kill_or_term_starved(signal.SIGKILL)
elif MODE == "term-starved":
    good, text = kill_or_term_starved(signal.SIGTERM)
elif MODE == "term-stalled":
    good, text = kill_or_term_stalled(signal.SIGTERM)
elif MODE == "kill9-stalled":
    good, text = kill_or_term_stalled(signal.SIGKILL)
else:
    sys.exit(__doc__)
say("RESULT mode=%s seed=%d trials=%d %s: %s (loadavg %s)" % (
    MODE, SEED, TRIALS, "PASS" if good else "FAIL", text, S.loadavg()))
