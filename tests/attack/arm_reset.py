#!/usr/bin/env python3
"""The arm controller resets mid-task (power cycle): after Engage, ajar-armsim is killed and a
fresh one (no memory of the task) appears at the same device path, reporting idle. The arm may
still hold the handle. Does the daemon let the base move (Drive / Approach / AlignBase) with or
without a Stop / Reset?

Usage: arm_reset.py [variant: nostop|stop|reset] [trials]
"""
import glob
import os
import signal
import struct
import subprocess
import sys
import tempfile
import time

from ajarwire import *

variant = sys.argv[1] if len(sys.argv) > 1 else "stop"
trials = int(sys.argv[2]) if len(sys.argv) > 2 else 2
lib = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
armsim_bin = os.path.join(BUILD, "drivers", "armsim", "ajar-armsim")
link = os.path.join(tempfile.mkdtemp(prefix="ajar-armlink-"), "arm")


def start_arm():
    p = subprocess.Popen([armsim_bin, "--task-ms", "60000"], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True)
    dev = p.stdout.readline().strip()
    tmp = link + ".tmp"
    if os.path.lexists(tmp):
        os.unlink(tmp)
    os.symlink(os.path.realpath(dev), tmp)
    os.rename(tmp, link)
    return p


moved_in = 0
for trial in range(trials):
    arm = start_arm()
    d = Daemon({"drivers.kind": "real", "library": '"%s"' % lib, "device": link,
                "reconnect_min_ms": 50, "reconnect_max_ms": 200}, name="armreset")
    d.start()
    arm2 = None
    try:
        c = d.conn(0)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
        engage_ready(c)
        e = c.call(ENGAGE)
        time.sleep(0.3)
        say("trial %d (%s): engage %s, status %s" % (trial, variant, e, c.status()))
        arm.send_signal(signal.SIGKILL)
        arm.wait()
        arm2 = start_arm()
        if variant in ("stop", "reset"):
            say("  Stop ->", c.call(STOP))
        # wait for the link to come back and report idle
        t0 = time.monotonic()
        while time.monotonic() - t0 < 5:
            st = c.status()
            if st["arm"] == "idle" and st["arm_link"] == 2:
                break
            c.call(PING, b"\0" * 8)
            time.sleep(0.1)
        say("  fresh arm controller: status %s after %.1f s" % (st, time.monotonic() - t0))
        if variant == "reset":
            say("  Reset ->", c.call(RESET, b"\x00"))
            say("  Reset(clear) ->", c.call(RESET, b"\x01"))
            measure_all(c, plane=True)
        obs.poll(0.2)
        n0 = len(obs.telems())
        acc = []
        for mt, pl in ((DRIVE, drive(0.1, 0.0)), (APPROACH, struct.pack("<d", 0.6)), (ALIGN, b"")):
            r = c.call(mt, pl)
            acc.append((hex(mt), "ACK" if ok(r) else err(r)))
            for _ in range(5):
                c.call(DRIVE, drive(0.1, 0.0)) if mt == DRIVE else c.call(PING, b"\0" * 8)
                obs.poll(0.1)
        obs.poll(0.5)
        tel = obs.telems()[n0:]
        lw = [t["left_rad"] for t in tel]
        travel = (max(lw) - min(lw)) * 0.1 if lw else 0
        st = c.status()
        say("  motion commands: %s; wheel travel %.4f m; final %s fault=%d" % (
            acc, travel, st["state"], st["fault"]))
        if travel > 1e-3:
            moved_in += 1
    finally:
        d.stop()
        for p in (arm, arm2):
            if p and p.poll() is None:
                p.terminate()
                p.wait()
say("RESULT variant=%s trials=%d moved_in=%d" % (variant, trials, moved_in))
