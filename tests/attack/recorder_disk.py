#!/usr/bin/env python3
"""The black box's disk goes bad under a running ajard: the recorder directory on a tiny tmpfs that
fills up, then remounted read-only mid-run, then writable again (needs root: mount).

While that happens a controller jogs and pings (ping round trips measured), an observer takes
telemetry at 100 Hz. Checks: the control loop does not notice (loop overruns and period max from
Status, before vs during), the sessions do not notice (ping round-trip p99/max during vs before; no
session closed), jogs keep being accepted, the journal says the recorder failed (once per episode,
not a flood), and after the disk is back the recorder writes again.

Usage: recorder_disk.py [seconds per phase]      (KIND=sim|mock, default sim)
"""
import os
import statistics
import struct
import subprocess
import sys
import time

from ajarwire import *

phase_s = float(sys.argv[1]) if len(sys.argv) > 1 else 4.0
kind = os.environ.get("KIND", "sim")
d = Daemon({"drivers.kind": kind, "recorder.loop_decimation": 1}, name="recdisk")
rec = os.path.join(d.dir, "recordings")
os.makedirs(rec)
subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k,mode=0750", "tmpfs", rec], check=True)
fails = []


def loop_stats(c):
    m = c.call(STATUS)
    p = m.p
    rate, cycles, overruns, p50, p99, pmax, j99 = struct.unpack_from("<fQQIIII", p, 249)
    return cycles, overruns, pmax


def phase(c, obs, name, seconds):
    rtts = []
    accepted = refused = 0
    cyc0, ovr0, _ = loop_stats(c)
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        t = time.monotonic()
        r = c.call(PING, b"\0" * 8, timeout=5)
        if r is None:
            fails.append("%s: a Ping got no reply within 5 s" % name)
        rtts.append(time.monotonic() - t)
        r = c.call(DRIVE, drive(0.05 if int(t * 2) % 2 else -0.05, 0.0))
        accepted += ok(r)
        refused += not ok(r)
        obs.poll(0.02)
    cyc1, ovr1, pmax = loop_stats(c)
    rtts.sort()
    p99 = rtts[int(len(rtts) * 0.99) - 1] if rtts else 0
    say("%-22s pings %4d rtt p50 %.2f ms p99 %.2f ms max %.2f ms; Drive acked %d refused %d; "
        "loop cycles %d overruns %d (period max %.2f ms)" % (
            name, len(rtts), statistics.median(rtts) * 1e3, p99 * 1e3, rtts[-1] * 1e3, accepted,
            refused, cyc1 - cyc0, ovr1 - ovr0, pmax / 1e6))
    return p99, ovr1 - ovr0, refused


try:
    d.start()
    c = d.conn(0)
    obs = d.conn(1)
    obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
    c.call(RESET, b"\x01")
    base = phase(c, obs, "baseline (disk fills)", phase_s)
    say("  recordings: %s" % sorted(os.listdir(rec)))
    full = phase(c, obs, "tmpfs full", phase_s)
    subprocess.run(["mount", "-o", "remount,ro", rec], check=True)
    ro = phase(c, obs, "read-only", phase_s)
    subprocess.run(["mount", "-o", "remount,rw,size=4m", rec], check=True)
    for f in os.listdir(rec):
        if f.endswith(".mcap"):
            try:
                os.unlink(os.path.join(rec, f))
            except OSError:
                pass
    back = phase(c, obs, "writable again (4 MiB)", max(phase_s, 6.0))
    files = sorted(os.listdir(rec))
    say("  recordings after: %s" % files)
    if obs.closed or c.closed:
        fails.append("a session was closed")
    for name, r in (("full", full), ("read-only", ro)):
        if r[1] > base[1] + 2:
            fails.append("%s: loop overruns %d vs %d at baseline" % (name, r[1], base[1]))
        if r[0] > max(0.05, 5 * base[0]):
            fails.append("%s: ping p99 %.1f ms vs %.1f ms at baseline" % (name, r[0] * 1e3,
                                                                        base[0] * 1e3))
        if r[2]:
            fails.append("%s: %d Drives refused" % (name, r[2]))
    log = d.log()
    lines = [l for l in log.splitlines() if "recorder" in l and ("fail" in l or "paused" in l)]
    say("  journal lines about the recorder's disk: %d" % len(lines))
    for l in lines[:6]:
        say("    " + l[:200])
    if len(lines) > 20:
        fails.append("the journal is flooded: %d recorder lines" % len(lines))
    if not any(f.endswith(".mcap") and os.path.getsize(os.path.join(rec, f)) > 0 for f in files):
        fails.append("the recorder did not write again once the disk was back")
    c.call(DRIVE, drive(0.0, 0.0))
finally:
    d.stop()
    subprocess.run(["umount", "-l", rec])
say("%d failures" % len(fails))
for f in fails:
    say("  FAIL " + f)
sys.exit(1 if fails else 0)
