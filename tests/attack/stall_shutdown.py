#!/usr/bin/env python3
"""A stalled control loop (a card call that never returns) meets SIGTERM and EmergencyStop.

Usage: stall_shutdown.py [release_after_s]
Jog, hang the next GT_* call (AJAR_SIM_BLOCK_FILE), SIGTERM, EmergencyStop: is the stop acked, does
ajard exit within a bound (or wedge forever), and after a restart is a fault latched?
"""
import os
import signal
import struct
import sys
import time

from ajarwire import *

release = float(sys.argv[1]) if len(sys.argv) > 1 else -1
block = "/tmp/ajar-attack-stallterm-%d" % os.getpid()
d = Daemon({"drivers.kind": "sim", "stall_timeout_s": 0.2}, env={"AJAR_SIM_BLOCK_FILE": block},
           name="stallterm")
d.start()
c = d.conn(0)
c.call(RESET, b"\x01")
measure_all(c, plane=False)
for _ in range(5):
    c.call(DRIVE, drive(0.2, 0.0))
    time.sleep(0.05)
open(block, "w").close()
time.sleep(0.6)
say("status while stalled:", c.status())
t0 = time.monotonic()
d.signal(signal.SIGTERM)
time.sleep(0.02)
e = c.call(ESTOP, timeout=3)
say("SIGTERM while stalled; EmergencyStop -> %s (%.0f ms)" % (e, (time.monotonic() - t0) * 1e3))
try:
    s2 = Conn(d.port)
    say("new connection during shutdown; Stop ->", s2.call(STOP, timeout=3))
except OSError as ex:
    say("new connection during shutdown refused: %s (%.0f ms after SIGTERM)" % (
        ex, (time.monotonic() - t0) * 1e3))
rc = None
end = time.monotonic() + 20
released = False
while time.monotonic() < end:
    if release >= 0 and not released and time.monotonic() - t0 > release:
        os.unlink(block)
        released = True
        say("released the hung call at +%.1f s" % (time.monotonic() - t0))
    rc = d.p.poll()
    if rc is not None:
        break
    time.sleep(0.1)
say("ajard exit code %s after %.1f s" % (rc, time.monotonic() - t0))
if os.path.exists(block):
    os.unlink(block)
if rc is None:
    say("WEDGED: ajard did not exit 20 s after SIGTERM with a hung card call; log tail:")
    say(d.log()[-1500:])
    d.kill9()
d.start()
c = d.conn(0)
st = c.status()
r = c.call(DRIVE, drive(0.1, 0.0))
say("after restart: fault=%d state=%s Drive -> %s" % (st["fault"], st["state"], r))
d.stop()
