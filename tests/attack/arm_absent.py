#!/usr/bin/env python3
"""Positive arm interlock with no task: (a) the arm device absent from the start, (b) the arm
controller frozen (SIGSTOP) while idle. Does Drive move the base?  Usage: arm_absent.py"""
import glob, os, signal, struct, subprocess, time
from ajarwire import *
lib = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
armsim_bin = os.path.join(BUILD, "drivers", "armsim", "ajar-armsim")
for case in ("absent", "frozen-idle"):
    arm = None
    dev = "/tmp/ajar-no-such-arm"
    if case == "frozen-idle":
        arm = subprocess.Popen([armsim_bin], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        dev = arm.stdout.readline().strip()
    d = Daemon({"drivers.kind": "real", "library": '"%s"' % lib, "device": dev}, name="armabsent")
    try:
        d.start()
    except RuntimeError as e:
        say(case, "start refused:", str(e)[-200:]); continue
    try:
        c = d.conn(0)
        measure_all(c, plane=False)
        if arm:
            os.kill(arm.pid, signal.SIGSTOP)
            time.sleep(2.0)
        st = c.status()
        r = c.call(DRIVE, drive(0.1, 0.0))
        for _ in range(5):
            c.call(DRIVE, drive(0.1, 0.0)); time.sleep(0.1)
        st2 = c.status()
        say("%s: status before %s; Drive -> %s; odometry x moved %.4f m" % (case, {k: st[k] for k in ("state", "fault", "arm_link", "arm")}, r, st2["odo_x"] - st["odo_x"]))
    finally:
        d.stop()
        if arm:
            os.kill(arm.pid, signal.SIGCONT); arm.terminate(); arm.wait()
