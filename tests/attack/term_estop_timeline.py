#!/usr/bin/env python3
"""Item 4 in detail: jog at full speed, SIGTERM, EmergencyStop DELAY ms later from SENDER; prints
the wheel speed (observer telemetry, 500 Hz) every 20 ms around the Ack, and compares with a plain
EmergencyStop without SIGTERM (the baseline: how fast an e-stop halts the simulated wheels).

Usage: term_estop_timeline.py [delay_ms] [sender: controller|observer|ungreeted] [noterm]
"""
import signal
import struct
import sys
import time

from ajarwire import *

delay = float(sys.argv[1]) / 1e3 if len(sys.argv) > 1 else 0.005
who = sys.argv[2] if len(sys.argv) > 2 else "controller"
noterm = len(sys.argv) > 3 and sys.argv[3] == "noterm"
d = Daemon({"drivers.kind": "sim"}, name="termtl")
d.start()
c = d.conn(0)
c.call(RESET, b"\x01")
obs = d.conn(1)
obs.call(SUBSCRIBE, struct.pack("<f", 500.0))
other = Conn(d.port)  # un-greeted
measure_all(c, plane=False)
for _ in range(8):
    c.call(DRIVE, drive(0.25, 0.0))
    obs.poll(0.08)
sender = {"controller": c, "observer": obs, "ungreeted": other}[who]
tterm = time.monotonic()
if not noterm:
    d.signal(signal.SIGTERM)
time.sleep(delay)
rid = sender.cmd(ESTOP)
m = sender.reply(rid, 3)
obs.poll(1.0)
tack = m.t if m else time.monotonic()
say("SIGTERM%s, %s EmergencyStop %.1f ms later -> %s at +%.1f ms" % (
    " (NOT sent)" if noterm else "", who, delay * 1e3, m, (tack - tterm) * 1e3))
tel = [(x.t, parse_telem(x.p)) for x in obs.log if x.type == TELEM]
for i in range(1, len(tel)):
    pass
rows = []
i = 0
while i < len(tel):
    j = i
    while j < len(tel) and (tel[j][1]["t_ns"] - tel[i][1]["t_ns"]) < 20e6:
        j += 1
    if j >= len(tel):
        break
    a, b = tel[i][1], tel[j][1]
    v = (b["left_rad"] - a["left_rad"]) * 0.1 / ((b["t_ns"] - a["t_ns"]) * 1e-9)
    if -0.1 < tel[i][0] - tterm < 1.0:
        rows.append("  %+7.1f ms (recv, rel. SIGTERM)  v=%.3f m/s moving=%s state=%s" % (
            (tel[i][0] - tterm) * 1e3, v, b["moving"], b["state"]))
    i = j
for r in rows:
    say(r)
for x in c.log + obs.log:
    if x.type in (EVENT, ERROR) and x.t >= tterm - 0.01:
        say("  %+7.1f ms %s" % ((x.t - tterm) * 1e3, x))
d.stop()
say("exit", d.p.returncode)
