#!/usr/bin/env python3
"""kill -9 of ajard at random instants — during the black box's fast rotation (tiny
recorder.max_file_bytes and max_bytes, every loop cycle recorded) and during the procedure (durable
measurements, AlignBase, jogs) — then a restart on the same state and recording directories.

Checks after each restart:
  - a fault is latched (the one latched before, or UNCLEAN_SHUTDOWN 519) and Drive is refused;
  - every measurement whose Ack arrived before the kill is restored (has_width/handle/plane);
  - every recording file reads as MCAP up to its last whole record (magic, then records; a cut
    tail is allowed); the file that was being written at the kill has a message logged no earlier
    than ~1 s (plus one flush) before the kill (docs/blackbox.md: at most ~0.1 s lost to a kill -9);
  - the rotation budget: the recordings (saved/ excepted) fit max_bytes + one max_file_bytes.

Usage: kill9_recorder.py [trials] [seed]    (KIND=sim|mock, default sim)
"""
import os
import random
import struct
import sys
import time

from ajarwire import *

MAGIC = b"\x89MCAP0\r\n"


def read_mcap(path):
    """(whole records, last Message log_time ns or None, cut tail bytes, footer seen)."""
    data = open(path, "rb").read()
    if len(data) < 8:
        return 0, None, len(data), False
    if data[:8] != MAGIC:
        raise ValueError("%s: bad magic %r" % (path, data[:8]))
    pos, n, last, footer = 8, 0, None, False
    while pos + 9 <= len(data):
        op, ln = struct.unpack_from("<BQ", data, pos)
        if pos + 9 + ln > len(data):
            break
        body = data[pos + 9:pos + 9 + ln]
        if op == 0x05 and ln >= 22:  # Message: channel u16, sequence u32, log_time u64, ...
            last = max(last or 0, struct.unpack_from("<Q", body, 6)[0])
        if op == 0x02:
            footer = True
        if op == 0 or op > 0x10:
            raise ValueError("%s: opcode %#x at %d" % (path, op, pos))
        pos += 9 + ln
        n += 1
    tail = len(data) - pos
    if footer and data[pos:] != MAGIC:
        raise ValueError("%s: footer without the closing magic" % path)
    return n, last, (0 if footer else tail), footer


def recordings(d):
    rd = os.path.join(d.dir, "recordings")
    if not os.path.isdir(rd):
        return []
    return sorted(os.path.join(rd, f) for f in os.listdir(rd) if f.endswith(".mcap"))


trials = int(sys.argv[1]) if len(sys.argv) > 1 else 10
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
kind = os.environ.get("KIND", "sim")
MAXF, MAXB = 64 * 1024, 1024 * 1024  # the smallest the config allows
d = Daemon({"drivers.kind": kind, "recorder.max_file_bytes": MAXF, "recorder.max_bytes": MAXB,
            "recorder.loop_decimation": 1, "recorder.max_file_s": 2}, name="kill9rec")
fails = []


def fail(line):
    say("  FAIL " + line)
    fails.append(line)


try:
    d.start()
    for trial in range(trials):
        c = d.conn(0, take_over=True)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 50.0))
        c.call(STOP)
        c.call(RESET, b"\x01")
        acked = {}
        what = rng.choice(["measure", "align", "jog", "idle"])
        steps = [("has_width", WIDTH, WIDTH_PTS), ("has_handle", HANDLE, HANDLE_PTS),
                 ("has_plane", PLANE, plane_pts(0.15))]
        kill_after = rng.uniform(0.0, 0.8)
        t0 = time.monotonic()
        killed_at = None
        if what == "measure":
            # Kill while the measurements' durable Acks come back: in flight or just acked.
            rids = []
            for key, t, p in steps:
                rids.append((key, c.cmd(t, p)))
            time.sleep(rng.uniform(0, 0.01))
            c.poll(0)
            for key, rid in rids:
                m = next((x for x in c.log if x.rid == rid), None)
                acked[key] = ok(m)
            killed_at = time.time()
            d.kill9()
        else:
            for key, t, p in steps:
                acked[key] = ok(c.call(t, p))
            if what == "align":
                c.call(ALIGN)
            elif what == "jog":
                c.call(DRIVE, drive(0.1, 0.2))
            while time.monotonic() - t0 < kill_after:
                if what == "jog":
                    c.cmd(DRIVE, drive(0.1, 0.2))
                c.poll(0.05)
            killed_at = time.time()
            d.kill9()
        files_before = recordings(d)
        say("trial %d: %s, SIGKILL after %.3f s; acked %s; %d recording files" % (
            trial, what, time.monotonic() - t0, acked, len(files_before)))
        # The recordings as the kill left them.
        newest = files_before[-1] if files_before else None
        total = 0
        for f in files_before:
            total += os.path.getsize(f)
            try:
                n, last, tail, footer = read_mcap(f)
            except ValueError as e:
                fail("trial %d: %s" % (trial, e))
                continue
            if f == newest:
                if last is None:
                    fail("trial %d: the file being written at the kill has no message (%s)" % (
                        trial, os.path.basename(f)))
                else:
                    lag = killed_at - last / 1e9
                    say("  newest %s: %d records, cut tail %d B, footer %s, last message %.3f s "
                        "before the kill" % (os.path.basename(f), n, tail, footer, lag))
                    if lag > 1.2:
                        fail("trial %d: %.3f s of recording lost to the kill (> ~1 s)" % (trial, lag))
        if total > MAXB + 2 * MAXF:
            fail("trial %d: recordings hold %d bytes > max_bytes %d + max_file_bytes" % (
                trial, total, MAXB))
        # Restart: the fault, the measurements.
        d.start()
        c2 = d.conn(0, take_over=True)
        st = c2.status()
        r = c2.call(DRIVE, drive(0.1, 0.0))
        line = "trial %d: after restart fault=%d state=%s restored=%s has=%s Drive->%s" % (
            trial, st["fault"], st["state"], st["restored"],
            {k: st[k] for k in ("has_width", "has_handle", "has_plane")}, r)
        good = st["fault"] != 0 and not ok(r)
        for key, was in acked.items():
            if was and not st[key]:
                good = False
                line += " LOST %s (acked before the kill)" % key
        if good:
            say("  OK " + line)
        else:
            fail(line)
        c2.close()
        c.close()
        obs.close()
    d.stop()
    for f in recordings(d):
        n, last, tail, footer = read_mcap(f)
finally:
    if d.p and d.p.poll() is None:
        d.stop()
say("%d failures" % len(fails))
for f in fails:
    say("  " + f)
sys.exit(1 if fails else 0)
