#!/usr/bin/env python3
"""SIGHUP (config reload) while a black-box recording is fetched (protocol 1.2), with a controller
jogging and a Stop sent behind several outstanding FetchRecording requests.

Checks: every FetchRecording gets exactly one reply, in request order; the fetched bytes equal the
file's bytes on disk (the part that existed); the Stop behind queued fetches is acknowledged and
the jog stops (telemetry) even while fetch replies wait; no session is closed by the reloads.

Usage: fetch_hup.py [hups] [seed]      (KIND=sim|mock, default sim)
"""
import os
import random
import signal
import struct
import sys
import time

from ajarwire import *

LIST, FETCH, SAVE, RLIST, CHUNK = 0x150, 0x151, 0x152, 0x209, 0x20A
OUT_OF_RANGE = 209  # REQUEST_OUT_OF_RANGE
hups = int(sys.argv[1]) if len(sys.argv) > 1 else 30
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
kind = os.environ.get("KIND", "sim")
d = Daemon({"drivers.kind": kind}, name="fetchhup")
fails = []


def hello12(role):
    return struct.pack("<BBBBQ", 1, 2, role, 0, 0) + s32("fetchhup")


def str48(t):
    b = t.encode()
    return bytes([len(b)]) + b + b"\0" * (48 - len(b))


try:
    d.start()
    c = d.conn(0)
    obs = Conn(d.port)
    m = obs.call(HELLO, hello12(1), minor=2)
    assert m.type == WELCOME, m
    obs.call(SUBSCRIBE, struct.pack("<f", 100.0), minor=2)
    c.call(RESET, b"\x01")
    time.sleep(1.0)
    rid = obs.cmd(LIST, struct.pack("<I", 0), minor=2)
    lst = obs.wait(lambda m: m.rid == rid, 5)
    assert lst is not None and lst.type == RLIST, lst
    count = lst.p[8]
    name = lst.p[9 + 1:9 + 1 + lst.p[9]].decode()
    path = os.path.join(d.dir, "recordings", name)
    say("fetching", name, "(%d recordings)" % count)
    data = b""
    rids_in_order = []
    hup_left = hups
    stop_checked = False
    t0 = time.monotonic()
    while time.monotonic() - t0 < 30:
        # Several fetches outstanding at once, a SIGHUP between them sometimes.
        batch = []
        for k in range(rng.randint(1, 6)):
            f, rid = obs.req(FETCH, str48(name) + struct.pack("<QH", len(data) + 960 * k, 960),
                             minor=2)
            batch.append((f, rid, len(data) + 960 * k))
        stop_rid = None
        blob = b"".join(f for f, _, _ in batch)
        if not stop_checked and len(data) > 20000:
            # A jog, then the observer's Stop queued behind its own fetches, in one write.
            for _ in range(5):
                c.call(DRIVE, drive(0.2, 0.0))
                time.sleep(0.05)
            fs, stop_rid = obs.req(STOP, minor=2)
            blob += fs
            tstop = time.monotonic()
        cut = rng.randint(0, len(blob))
        obs.send(blob[:cut])
        if hup_left > 0 and rng.random() < 0.7:
            d.signal(signal.SIGHUP)
            hup_left -= 1
        obs.send(blob[cut:])
        got = []
        for _, rid, off in batch:
            r = obs.wait(lambda m, rid=rid: m.rid == rid, 5)
            if r is None:
                fails.append("no reply to FetchRecording #%d" % rid)
                continue
            got.append(r)
            if r.type == ERROR and err(r) == OUT_OF_RANGE:
                continue  # asked past the end of the file (several ahead at once)
            if r.type != CHUNK:
                fails.append("FetchRecording #%d: %s" % (rid, r))
                continue
            o, size, ln = struct.unpack_from("<QQH", r.p, 0)
            if o == len(data):
                data += r.p[18:18 + ln]
        idx = [obs.log.index(r) for r in got]
        if idx != sorted(idx):
            fails.append("replies out of request order: %s" % [r.rid for r in got])
        if stop_rid is not None:
            r = obs.wait(lambda m: m.rid == stop_rid, 5)
            if not ok(r):
                fails.append("the Stop behind the fetches: %s" % r)
            time.sleep(0.5)
            obs.poll(0.1)
            tel = obs.telems()[-5:]
            if any(t["moving"] for t in tel):
                fails.append("the base still moves 0.5 s after the Stop")
            say("Stop behind %d fetches: %s, base at rest after: %s" % (
                len(batch), "ACK" if ok(r) else r, not any(t["moving"] for t in tel)))
            stop_checked = True
        if got and got[-1].type == CHUNK and struct.unpack_from("<H", got[-1].p, 16)[0] == 0 \
                and len(data) > 60000:
            break
    disk = open(path, "rb").read()
    same = disk[:len(data)] == data
    say("fetched %d bytes over %d SIGHUPs; equal to the file on disk: %s; sessions open: %s" % (
        len(data), hups - hup_left, same, not (obs.closed or c.closed)))
    if not same:
        fails.append("the fetched bytes differ from the file")
    if obs.closed or c.closed:
        fails.append("a session was closed")
    reloads = d.log().count("reload")
    say("journal lines mentioning reload: %d" % reloads)
finally:
    d.stop()
say("%d failures" % len(fails))
for f in fails:
    say("  FAIL " + f)
sys.exit(1 if fails else 0)
