#!/usr/bin/env python3
"""A Stop behind a held durable Ack, on the running daemon: the state writer hangs (the state
file's temporary made a FIFO nobody reads: a save that never lands), the base jogs, and one TCP
write carries a measurement (its Ack is held for the save, at most 2 s) and a Stop (variants:
measurement + Stop, measurement + Drive + Stop, Stop + measurement, two measurements + EStop).

Checks: the wheels start decelerating within ~50 ms of the write (the Stop acted at once, not when
the held Ack was released); on the controller's connection the replies come in request order (the
measurement's Ack first, then the Stop's) and the stop's events (motion_stopped, for an EStop
fault_latched) come after the Stop's Ack; the observer gets the events without waiting; the Ack is
released within ~2 s (kHeldReplyLimit) although the disk never finished.

Usage: held_ack_stop.py [rounds]     (KIND=sim|mock, default sim)
"""
import os
import struct
import sys
import threading
import time

from ajarwire import *

rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 2
kind = os.environ.get("KIND", "sim")
d = Daemon({"drivers.kind": kind}, name="heldack")
fails = []
VARIANTS = [("W+S", [WIDTH, STOP]), ("W+D+S", [WIDTH, DRIVE, STOP]), ("S+W", [STOP, WIDTH]),
            ("W+H+E", [WIDTH, HANDLE, ESTOP])]
PAYLOAD = {WIDTH: WIDTH_PTS, HANDLE: HANDLE_PTS, STOP: b"", ESTOP: b"", DRIVE: drive(0.2, 0.0)}


def wheel_speed(tel, t_from, t_to):
    pts = [(m.t, parse_telem(m.p)) for m in tel if t_from <= m.t <= t_to]
    if len(pts) < 2:
        return None
    (ta, a), (tb, b) = pts[0], pts[-1]
    dt = (b["t_ns"] - a["t_ns"]) * 1e-9
    return abs(b["left_rad"] - a["left_rad"]) * 0.1 / dt if dt > 0 else None


try:
    d.start()
    tmp = os.path.join(d.state_dir, "ajard.state.tmp")
    for rnd in range(rounds):
        for name, types in VARIANTS:
            c = d.conn(0, take_over=True)
            obs = d.conn(1)
            obs.call(SUBSCRIBE, struct.pack("<f", 200.0))
            c.call(STOP)
            c.call(RESET, b"\x01")
            for _ in range(8):
                c.call(DRIVE, drive(0.2, 0.0))
                obs.poll(0.05)
            if os.path.exists(tmp):
                os.unlink(tmp)
            os.mkfifo(tmp)  # the next save hangs in open()
            frames, rids = b"", []
            for t in types:
                f, rid = c.req(t, PAYLOAD[t])
                frames += f
                rids.append((t, rid))
            n_obs = len(obs.log)
            t0 = time.monotonic()
            c.send(frames)
            c.poll(0.3)
            obs.poll(0.0)
            v_before = wheel_speed(obs.log[:n_obs], t0 - 0.2, t0)
            v_after = wheel_speed(obs.log, t0 + 0.05, t0 + 0.25)
            # Wait for every reply (the held one within ~2 s), then release the writer.
            got = [c.wait(lambda m, r=r: m.rid == r, 5) for _, r in rids]
            t_last = time.monotonic() - t0
            # Unblock the hung save: open the FIFO for reading and drain it.
            rd = os.open(tmp, os.O_RDONLY | os.O_NONBLOCK)
            time.sleep(0.2)
            try:
                os.read(rd, 1 << 20)
            except BlockingIOError:
                pass
            os.close(rd)
            if os.path.exists(tmp):
                os.unlink(tmp)
            order = [c.log.index(m) for m in got if m is not None]
            stop_rid = [r for t, r in rids if t in (STOP, ESTOP)][0]
            stop_reply = next(m for m in got if m is not None and m.rid == stop_rid)
            i_stop = c.log.index(stop_reply)
            ev_after = [parse_event(m.p)[0] for m in c.log[i_stop + 1:] if m.type == EVENT]
            ev_before = [parse_event(m.p)[0] for m in c.log[:i_stop]
                         if m.type == EVENT and m.t >= t0]
            obs_ev = [(round(m.t - t0, 3), parse_event(m.p)[0]) for m in obs.log[n_obs:]
                      if m.type == EVENT]
            stopped_ev = "motion_stopped" in ev_after or "motion_stopped" in ev_before
            line = ("%-6s replies %s in %.2f s; wheel speed %.3f -> %.3f m/s 50-250 ms after the "
                    "write; controller events before the Stop's Ack %s, after %s; observer %s" % (
                        name, [describe(m) if m else None for m in got], t_last, v_before or 0,
                        v_after or 0, ev_before, ev_after[:3], obs_ev[:3]))
            good = (all(m is not None for m in got) and order == sorted(order) and
                    v_after is not None and v_before and v_after < 0.5 * v_before and
                    "motion_stopped" not in ev_before and t_last < 3.5)
            say(("  OK " if good else "  FAIL ") + line)
            if not good:
                fails.append(line)
            c.close()
            obs.close()
finally:
    d.stop()
say("%d failures" % len(fails))
sys.exit(1 if fails else 0)
