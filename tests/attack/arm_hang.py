#!/usr/bin/env python3
"""Item 2: Engage, then the arm controller hangs (SIGSTOP of ajar-armsim on its pty), Stop, then
Drive / Approach / AlignBase / Reset. Does the base ever move while the arm is silent?

Usage: [STOPKIND=estop] [CLEAR=1] arm_hang.py [trials]
Runs ajard with drivers.kind: real, the card simulator library as the "vendor" library and the
arm at a separate ajar-armsim process (so it can be stopped).
"""
import glob
import os
import signal
import struct
import subprocess
import sys
import time

from ajarwire import *

trials = int(sys.argv[1]) if len(sys.argv) > 1 else 4
lib = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
armsim_bin = os.path.join(BUILD, "drivers", "armsim", "ajar-armsim")

moved_total = 0
accepted_total = 0
for trial in range(trials):
    arm = subprocess.Popen([armsim_bin, "--task-ms", "60000"], stdout=subprocess.PIPE,
                           stderr=subprocess.DEVNULL, text=True)
    dev = arm.stdout.readline().strip()
    d = Daemon({"drivers.kind": "real", "library": '"%s"' % lib, "device": dev}, name="armhang")
    d.start()
    try:
        c = d.conn(0)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 200.0))
        measure_all(c, plane=True)
        a = c.call(ALIGN)
        c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] == "motion_finished", 15)
        cp = c.call(CONTACT, CONTACT_PT)
        e = c.call(ENGAGE)
        time.sleep(0.3)
        st = c.status()
        say("trial %d: align %s contact %s engage %s -> %s arm=%s" % (trial, a, cp, e, st["state"],
                                                                     st["arm"]))
        os.kill(arm.pid, signal.SIGSTOP)
        time.sleep(0.05 * (trial % 4))
        s = c.call(ESTOP if os.environ.get("STOPKIND") == "estop" else STOP)
        say("  %s ->" % os.environ.get("STOPKIND", "stop"), s)
        if os.environ.get("CLEAR"):
            time.sleep(1.5)
            say("  Reset(clear_parameters) while the arm is silent ->", c.call(RESET, b"\x01"))
            say("  re-measure:", measure_all(c, plane=True))
        accepted = []
        obs.poll(0.1)
        n0 = len(obs.telems())
        t0 = time.monotonic()
        while time.monotonic() - t0 < 4.0:
            for mt, pl in ((DRIVE, drive(0.1, 0.0)), (APPROACH, struct.pack("<d", 0.6)),
                           (ALIGN, b""), (RESET, b"\x00"), (DRIVE, drive(0.0, 0.3))):
                r = c.call(mt, pl, timeout=2)
                if ok(r):
                    accepted.append((round(time.monotonic() - t0, 2), hex(mt)))
            obs.poll(0.05)
        tel = obs.telems()[n0:]
        left = [t["left_rad"] for t in tel]
        moved = (max(left) - min(left)) * 0.1 if left else 0
        odo = [(t["odo_x"], t["yaw"]) for t in tel]
        st = c.status()
        say("  while arm silent: accepted %s; wheel travel %.4f m; status %s fault=%d arm=%s" %
            (accepted[:8], moved, st["state"], st["fault"], st["arm"]))
        say("  events:", [e for e in c.events() if e[0] != "control_changed"][-6:])
        accepted_total += len([a for a in accepted if a[1] != hex(RESET)])
        if moved > 0.001:
            moved_total += 1
        os.kill(arm.pid, signal.SIGCONT)
        time.sleep(1.0)
        r = c.call(RESET, b"\x00")
        st = c.status()
        say("  after SIGCONT: Reset -> %s, status %s fault=%d arm=%s" % (r, st["state"], st["fault"],
                                                                         st["arm"]))
    finally:
        d.stop()
        os.kill(arm.pid, signal.SIGCONT)
        arm.terminate()
        arm.wait()
say("RESULT trials=%d moved_in=%d motion_commands_accepted=%d" % (trials, moved_total,
                                                                   accepted_total))
