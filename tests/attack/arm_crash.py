#!/usr/bin/env python3
"""Engage (arm busy with a 60 s task), then ajard is killed (-9) or SIGTERMed; restart with the arm
(a) still busy, (b) frozen (SIGSTOP). Reset, then Drive/Approach: does the base move while the arm
has not reported clear since its task?  Usage: arm_crash.py"""
import glob, os, signal, struct, subprocess, time
from ajarwire import *
lib = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
armsim_bin = os.path.join(BUILD, "drivers", "armsim", "ajar-armsim")
for how in ("kill9", "term"):
  for armcase in ("busy", "frozen"):
    arm = subprocess.Popen([armsim_bin, "--task-ms", "60000"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    dev = arm.stdout.readline().strip()
    d = Daemon({"drivers.kind": "real", "library": '"%s"' % lib, "device": dev}, name="armcrash")
    d.start()
    try:
        c = d.conn(0)
        measure_all(c, plane=True)
        c.call(ALIGN)
        c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] == "motion_finished", 15)
        c.call(CONTACT, CONTACT_PT)
        e = c.call(ENGAGE)
        time.sleep(0.3)
        if armcase == "frozen":
            os.kill(arm.pid, signal.SIGSTOP)
        if how == "kill9":
            d.kill9()
        else:
            d.stop()
        try:
            d.start()
        except RuntimeError as ex:
            say("%s/%s: restart refused: %s" % (how, armcase, str(ex)[-160:])); continue
        c = d.conn(0)
        st = c.status()
        r0 = c.call(RESET, b"\x00")
        r1 = c.call(RESET, b"\x01")
        m = measure_all(c, plane=False)
        dr = c.call(DRIVE, drive(0.1, 0.0))
        ap = c.call(APPROACH, struct.pack("<d", 0.6))
        time.sleep(0.5)
        st2 = c.status()
        say("%s/%s: after restart fault=%d arm=%s; Reset %s, Reset(clear) %s; Drive %s Approach %s; moved %.4f m; final arm=%s fault=%d" % (
            how, armcase, st["fault"], st["arm"], "ACK" if ok(r0) else err(r0), "ACK" if ok(r1) else err(r1),
            "ACK" if ok(dr) else err(dr), "ACK" if ok(ap) else err(ap), st2["odo_x"] - st["odo_x"], st2["arm"], st2["fault"]))
    finally:
        d.stop()
        os.kill(arm.pid, signal.SIGCONT); arm.terminate(); arm.wait()
