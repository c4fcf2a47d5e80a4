#!/usr/bin/env python3
"""Attack 4 (arm) with the real ajar-armsim on its pty: kill -9 of the simulator mid-Engage (the
cable pulled), and its --fault modes (silent-mid-task, silent-mid-stop, reset-mid-task,
stop-ignored). Then Drive / Approach / AlignBase attempts for 4 s, Stop, Reset, 3 s of Drives.
Checks: no wheel turns while the arm has not reported idle; a fault latched, named.
Usage: armsim_modes.py [trials] [seed]"""
import glob, os, random, signal, struct, subprocess, sys, time
from ajarwire import *
trials = int(sys.argv[1]) if len(sys.argv) > 1 else 5
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed); rng = random.Random(seed)
lib = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
armsim_bin = os.path.join(BUILD, "drivers", "armsim", "ajar-armsim")
fails = 0
for t in range(trials):
    mode = rng.choice(os.environ.get("MODES", "kill9,silent-mid-task,silent-mid-stop,reset-mid-task,stop-ignored").split(","))
    args = [armsim_bin, "--task-ms", "3000"] + (["--fault", mode] if mode != "kill9" else [])
    arm = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    dev = arm.stdout.readline().strip()
    d = Daemon({"drivers.kind": "real", "library": '"%s"' % lib, "device": dev}, name="armsim")
    d.start()
    try:
        c = d.conn(0); obs = d.conn(1); obs.call(SUBSCRIBE, struct.pack("<f", 50.0))
        engage_ready(c)
        e = c.call(ENGAGE)
        delay = rng.uniform(0.1, 1.2)
        t0 = time.monotonic()
        while time.monotonic() - t0 < delay: c.cmd(PING, b"\0"*8); c.poll(0.05)
        if mode == "kill9": arm.kill()
        n0 = len(obs.log)
        tries = []
        t0 = time.monotonic()
        while time.monotonic() - t0 < 4:
            k = rng.choice(["drive", "approach", "align", "ping", "ping"])
            m = c.call(DRIVE, drive(0.2, 0)) if k == "drive" else c.call(APPROACH, struct.pack("<d", 0.6)) if k == "approach" else c.call(ALIGN) if k == "align" else c.call(PING, b"\0"*8)
            if k != "ping": tries.append(describe(m) if m else None)
            obs.poll(0.05)
        s1 = c.call(STOP)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 3: c.cmd(PING, b"\0"*8); c.poll(0.05); obs.poll(0)
        rr = c.call(RESET, b"\x00")
        t0 = time.monotonic(); after = []
        while time.monotonic() - t0 < 3: m = c.call(DRIVE, drive(0.2, 0)); after.append(describe(m) if m else None); obs.poll(0.1)
        c.call(STOP); obs.poll(0.2)
        st = obs.status()
        tel = [parse_telem(x.p) for x in obs.log[n0:] if x.type == TELEM]
        arm_states = [x["arm"] for x in tel]
        # wheel turned while the arm had not reported idle?
        bad = False; idle_seen = False; prev = None
        for x in tel:
            if x["arm"] == "idle": idle_seen = True
            k = (x["left_counts"], x["right_counts"])
            if prev is not None and k != prev and not idle_seen: bad = True
            prev = k
        acc = [a for a in tries if a and a.startswith("Ack")]
        evs = [(ev[2], ev[3][:70]) for ev in obs.events() if ev[0] == "fault_latched"]
        good = not bad and not acc
        fails += not good
        say("%s trial %d %s (+%.2f s): engage %s; during: %d tries, %d acked; Stop %s; Reset %s; Drives after Reset acked %d/%d; wheels turned before an idle report: %s; arm states seen %s; faults %s; last Drive %s; fault now %d" % (
            "OK  " if good else "FAIL", t, mode, delay, describe(e) if e else None, len(tries), len(acc), describe(s1) if s1 else None,
            describe(rr) if rr else None, len([a for a in after if a and a.startswith("Ack")]), len(after), bad, sorted(set(arm_states)), evs[:3], after[-1], st["fault"]))
        c.close(); obs.close()
    finally:
        rc = d.stop()
        if arm.poll() is None: arm.terminate(); arm.wait()
        if rc != 0: say("   ajard exit", rc)
say("RESULT seed=%d fails=%d" % (seed, fails))
