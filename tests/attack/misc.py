#!/usr/bin/env python3
"""Item 9, more: the deadman against a trickling controller, a full session table, reconnect storms.

Usage: misc.py [seed]
 trickle   Approach, then the controller sends one Ping frame one byte every 0.3 s (a frame that
           never completes within the deadman): is the deadman fed by partial bytes?
 fulltable max_clients: 20, 19 idle un-greeted + observers, the controller jogs; a new connection
           sends EmergencyStop: acked and latched?
 storm     300 connect/Hello/close cycles (random roles, take-over among them) while a controller
           jogs; the daemon survives and a Stop from the controller is acked at the end.
"""
import random
import socket
import struct
import sys
import time

from ajarwire import *

seed = int(sys.argv[1]) if len(sys.argv) > 1 else int(time.time())
rng = random.Random(seed)
say("seed", seed)
d = Daemon({"drivers.kind": "sim", "max_clients": 20, "deadman_timeout_s": 1.0,
            "read_deadline_s": 10}, name="misc")
d.start()
try:
    # trickle
    c = d.conn(0)
    measure_all(c, plane=False)
    obs = d.conn(1)
    a = c.call(APPROACH, struct.pack("<d", 0.45))
    t0 = time.monotonic()
    f = frame(PING, b"\0" * 8, 999)
    sent = 0
    while time.monotonic() - t0 < 5 and sent < len(f):
        c.send(f[sent:sent + 1])
        sent += 1
        time.sleep(0.3)
        ev = [e for e in obs.events() if e[0] in ("fault_latched", "motion_finished",
                                                   "motion_stopped")]
        obs.poll(0)
        if ev:
            break
    ev = [(e[0], e[2]) for e in obs.events() if e[0] in ("fault_latched", "motion_finished",
                                                         "motion_stopped")]
    say("trickle: approach %s; after %.1f s of one byte per 0.3 s (%d bytes): events %s" % (
        a, time.monotonic() - t0, sent, ev))
    say("  -> %s" % ("deadman fired" if any(e[1] == 512 for e in ev) else
                     "NO DEADMAN: partial bytes kept the motion alive"))
    c.close()
    time.sleep(0.5)
    # fulltable
    c = d.conn(0, take_over=True)
    c.call(STOP)
    time.sleep(0.5)
    c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    idle = []
    for i in range(25):
        try:
            s = Conn(d.port)
            if i % 3 == 0:
                s.greet(1)
            idle.append(s)
        except OSError:
            pass
    c.call(DRIVE, drive(0.2, 0.0))
    n = Conn(d.port)
    rid = n.cmd(ESTOP)
    m = n.reply(rid, 3)
    st = c.status()
    say("fulltable: %d extra connections; newcomer's EmergencyStop -> %s; fault %s" % (
        len(idle), m, st and st["fault"]))
    for s in idle:
        s.close()
    n.close()
    # storm
    c = d.conn(0, take_over=True)
    c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    t0 = time.monotonic()
    nst = 0
    for i in range(300):
        if i % 10 == 0:
            c.call(DRIVE, drive(0.1, 0.0))
        try:
            s = Conn(d.port, timeout=2)
            kind = rng.random()
            if kind < 0.5:
                s.send(frame(HELLO, hello(1), 1))
            elif kind < 0.6:
                s.send(frame(HELLO, hello(0, False), 1))
            elif kind < 0.7:
                s.send(b"AJAR" + bytes(rng.randrange(256) for _ in range(rng.randint(0, 40))))
            elif kind < 0.8:
                s.s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            s.close()
            nst += 1
        except OSError:
            pass
    st = c.status()
    m = c.call(STOP)
    say("storm: %d connections in %.1f s; controller still controller=%s; Stop -> %s; alive=%s" %
        (nst, time.monotonic() - t0, st and st["controller"], m, d.p.poll() is None))
finally:
    d.stop()
