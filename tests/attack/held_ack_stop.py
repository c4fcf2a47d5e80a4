#!/usr/bin/env python3
"""A Stop behind a held durable Ack, on the running daemon: the state writer hangs (the state
file's temporary made a FIFO nobody reads: a save that never lands). Measurements are refused
while the base moves, so the held Ack comes first: one write carries MeasureDoorWidth (its Ack
held for the save, at most 2 s) and a Drive (the jog starts at once; its Ack waits behind the
held one); 0.3 s later, while both replies are still held, a Stop (or EmergencyStop) in its own
write. Variant "one write": Width + Drive + Stop together (the Stop cancels the Drive: nothing
may turn).

Checks: the wheels start decelerating within ~50 ms of the Stop (it acted at once, though its Ack
waits behind the held one); on the controller's connection the replies come in request order and
the stop's events (motion_stopped; for an EmergencyStop fault_latched) come after the Stop's Ack;
the held Ack is released within ~2 s although the disk never finished.

Usage: held_ack_stop.py [rounds]     (KIND=sim|mock, default sim)
"""
import os
import struct
import sys
import time

from ajarwire import *

rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 2
kind = os.environ.get("KIND", "sim")
d = Daemon({"drivers.kind": kind}, name="heldack")
fails = []
VARIANTS = [("then Stop", STOP, False), ("then EStop", ESTOP, False), ("one write", STOP, True)]


def wheel_speed(log, t_from, t_to):
    pts = [(m.t, parse_telem(m.p)) for m in log if m.type == TELEM and t_from <= m.t <= t_to]
    if len(pts) < 2:
        return None
    (ta, a), (tb, b) = pts[0], pts[-1]
    dt = (b["t_ns"] - a["t_ns"]) * 1e-9
    return abs(b["left_rad"] - a["left_rad"]) * 0.1 / dt if dt > 0 else None


try:
    d.start()
    tmp = os.path.join(d.state_dir, "ajard.state.tmp")
    for rnd in range(rounds):
        for name, stop_type, one_write in VARIANTS:
            c = d.conn(0, take_over=True)
            obs = d.conn(1)
            obs.call(SUBSCRIBE, struct.pack("<f", 200.0))
            c.call(STOP)
            c.call(RESET, b"\x01")
            obs.poll(0.3)
            if os.path.exists(tmp):
                os.unlink(tmp)
            os.mkfifo(tmp)  # the next save hangs in open()
            fw, rw = c.req(WIDTH, WIDTH_PTS)
            fd, rd_ = c.req(DRIVE, drive(0.2, 0.0))
            fs, rs = c.req(stop_type)
            t0 = time.monotonic()
            if one_write:
                c.send(fw + fd + fs)
                ts = t0
            else:
                c.send(fw + fd)
                c.poll(0.3)
                obs.poll(0.0)
                ts = time.monotonic()
                c.send(fs)
            c.poll(0.3)
            obs.poll(0.0)
            v_before = wheel_speed(obs.log, ts - 0.15, ts)
            v_after = wheel_speed(obs.log, ts + 0.05, ts + 0.25)
            held_at_stop = [m for m in c.log if m.rid in (rw, rd_) and m.t < ts]
            got = [c.wait(lambda m, r=r: m.rid == r, 5) for r in (rw, rd_, rs)]
            t_last = time.monotonic() - t0
            fifo = os.open(tmp, os.O_RDONLY | os.O_NONBLOCK)  # the hung save goes on
            time.sleep(0.2)
            try:
                os.read(fifo, 1 << 20)
            except BlockingIOError:
                pass
            os.close(fifo)
            if os.path.exists(tmp):
                os.unlink(tmp)
            order = [c.log.index(m) for m in got if m is not None]
            i_stop = c.log.index(got[2]) if got[2] is not None else len(c.log)
            ev_before = [parse_event(m.p)[0] for m in c.log[:i_stop]
                         if m.type == EVENT and m.t >= t0]
            ev_after = [parse_event(m.p)[0] for m in c.log[i_stop + 1:] if m.type == EVENT]
            obs_ev = [(round(m.t - ts, 3), parse_event(m.p)[0]) for m in obs.log
                      if m.type == EVENT and m.t >= t0]
            line = ("%-10s replies %s in %.2f s (held when the stop was sent: %s); wheel speed "
                    "%.3f -> %.3f m/s (50-250 ms after the stop); controller events before the "
                    "stop's Ack %s, after %s; observer %s" % (
                        name, [describe(m) if m else None for m in got], t_last,
                        not held_at_stop, v_before or 0, v_after or 0, ev_before, ev_after[:3],
                        obs_ev[:4]))
            if one_write:
                moved = (v_before or 0) > 0.005 or (v_after or 0) > 0.005
                good = all(got) and order == sorted(order) and not moved
            else:
                good = (all(got) and order == sorted(order) and not held_at_stop and
                        (v_before or 0) > 0.02 and (v_after or 0) < 0.5 * v_before and
                        "motion_stopped" not in ev_before and "motion_stopped" in ev_after)
            good = good and t_last < 3.5
            say(("  OK " if good else "  FAIL ") + line)
            if not good:
                fails.append(line)
            c.close()
            obs.close()
finally:
    d.stop()
say("%d failures" % len(fails))
sys.exit(1 if fails else 0)
