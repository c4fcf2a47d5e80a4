#!/usr/bin/env python3
"""Attack 4 (arm): a hand-written arm controller on a pseudo-terminal (docs/manipulator-serial.md)
that behaves until a door task is under way, then misbehaves at a random instant:
  hang        stops reading and answering (for good)
  unplug      closes the pty master (the cable is pulled: the daemon sees a hang-up)
  garbage     random bytes, over-long lines, lines with bad CRCs, mixed into its replies
  wrongid     valid CRC, wrong content: DONE/STA for another task id, an unknown phase, ACKs to
              requests never sent
  reset       comes back IDLE with task id 0 (forgot the task)
  stuckbusy   answers STOP with ACK ... BUSY and stays BUSY (arm never withdraws)
Meanwhile the controller keeps its session fed (Ping) and, after the mischief, tries Drive,
Approach and AlignBase. Checks: a fault is latched (ARM_*, named in the error), the wheels never
turn after the Engage, motion commands refused until a Reset; Reset refused (ARM_NOT_CLEAR) while
the arm does not report idle.

Usage: arm_liar.py [trials] [seed]
"""
import glob
import os
import pty
import random
import select
import struct
import sys
import tempfile
import threading
import time
import tty

from ajarwire import *

trials = int(sys.argv[1]) if len(sys.argv) > 1 else 6
seed = int(sys.argv[2]) if len(sys.argv) > 2 else int(time.time())
say("seed", seed)
rng = random.Random(seed)
SIMLIB = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]


def crc16(data):
    c = 0xFFFF
    for b in data:
        c ^= b << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) if c & 0x8000 else (c << 1)
            c &= 0xFFFF
    return c


assert crc16(b"123456789") == 0x29B1


def line(seq, body):
    inner = ("%d,%s" % (seq, body)).encode()
    return b"$" + inner + b"*%04X\r\n" % crc16(inner)


class FakeArm:
    def __init__(self, link, r):
        self.link = link
        self.r = r
        self.mode = None  # the mischief, once armed
        self.armed = threading.Event()
        self.phase = "IDLE"
        self.task = 0
        self.last_seq = None
        self.last_reply = b""
        self.log = []
        self.stop = False
        self.open()
        self.th = threading.Thread(target=self.run, daemon=True)
        self.th.start()

    def open(self):
        self.m, self.s = pty.openpty()
        tty.setraw(self.s)
        tty.setraw(self.m)
        tmp = self.link + ".tmp"
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(os.ttyname(self.s), tmp)
        os.rename(tmp, self.link)

    def send(self, b):
        try:
            os.write(self.m, b)
        except OSError:
            pass

    def handle(self, text):
        try:
            inner, crc = text[1:].split("*")
            if int(crc, 16) != crc16(inner.encode()):
                return
        except ValueError:
            return
        f = inner.split(",")
        seq, cmd = int(f[0]), f[1]
        self.log.append((time.monotonic(), cmd))
        if seq == self.last_seq:
            self.send(self.last_reply)
            return
        if cmd == "TASK":
            if self.phase in ("IDLE", "DONE"):
                self.task, self.phase = int(f[2]), "BUSY"
                self.task_t = time.monotonic()
                self.armed.set()
                rep = line(seq, "ACK,TASK,BUSY,%d" % self.task)
            else:
                rep = line(seq, "NAK,TASK,BUSY,%s,%d" % (self.phase, self.task))
        elif cmd == "STAT":
            rep = line(seq, "STA,%s,%d" % (self.phase, self.task))
        elif cmd == "STOP":
            if self.mode != "stuckbusy":
                self.phase = "IDLE"
            rep = line(seq, "ACK,STOP,%s,%d" % (self.phase, self.task))
        elif cmd == "CLR":
            if self.phase == "FAULT":
                self.phase = "IDLE"
            rep = line(seq, "ACK,CLR,%s,%d" % (self.phase, self.task))
        else:
            return
        self.last_seq, self.last_reply = seq, rep
        if self.mode == "garbage" and self.r.random() < 0.7:
            junk = self.r.choice([bytes(self.r.randrange(256) for _ in range(self.r.randint(1, 40))),
                                  b"$" + b"9" * 300 + b"\r\n",
                                  rep[:-7] + b"*0000\r\n",
                                  b"$$$,,**\n", rep[: self.r.randint(1, len(rep) - 1)]])
            self.send(junk)
        if self.mode == "wrongid" and self.r.random() < 0.7:
            self.send(self.r.choice([line(0, "DONE,%d" % (self.task + 1)),
                                     line(seq, "STA,DANCING,%d" % self.task),
                                     line(seq, "STA,DONE,%d" % (self.task + 7)),
                                     line((seq + 1) % 65536, "ACK,TASK,BUSY,99"),
                                     line(0, "DONE,0")]))
        self.send(rep)

    def run(self):
        buf = b""
        while not self.stop:
            m = self.m
            if self.mode == "hang" or m is None:
                time.sleep(0.05)
                continue
            try:
                r, _, _ = select.select([m], [], [], 0.05)
            except (OSError, ValueError):
                time.sleep(0.05)
                continue
            if not r:
                continue
            try:
                data = os.read(m, 4096)
            except OSError:
                time.sleep(0.05)
                continue
            buf += data
            while b"\n" in buf:
                ln, buf = buf.split(b"\n", 1)
                t = ln.strip().decode(errors="replace")
                if "$" in t:
                    self.handle(t[t.rindex("$"):])

    def misbehave(self, mode):
        self.mode = mode
        if mode == "unplug":
            m, s = self.m, self.s
            self.m = None
            os.close(m)
            os.close(s)
            os.unlink(self.link)
        elif mode == "reset":
            self.phase, self.task, self.last_seq = "IDLE", 0, None

    def close(self):
        self.stop = True
        for fd in (self.m, self.s):
            try:
                if fd is not None:
                    os.close(fd)
            except OSError:
                pass


fails = []
for trial in range(trials):
    mode = rng.choice(["hang", "unplug", "garbage", "wrongid", "reset", "stuckbusy"])
    link = os.path.join(tempfile.mkdtemp(prefix="ajar-armliar-"), "arm")
    arm = FakeArm(link, random.Random(seed * 100 + trial))
    d = Daemon({"drivers.kind": "real", "library": '"%s"' % SIMLIB, "device": link},
               name="armliar")
    d.start()
    probs = []
    try:
        c = d.conn(0)
        obs = d.conn(1)
        obs.call(SUBSCRIBE, struct.pack("<f", 100.0))
        engage_ready(c)
        e = c.call(ENGAGE)
        arm.armed.wait(3)
        delay = rng.uniform(0, 0.5)
        t0 = time.monotonic()
        while time.monotonic() - t0 < delay:
            c.cmd(PING, b"\0" * 8)
            c.poll(0.03)
        obs.poll(0)
        n_before = len(obs.log)
        arm.misbehave(mode)
        tm = time.monotonic()
        tries = []
        while time.monotonic() - tm < 4.0:
            c.cmd(PING, b"\0" * 8)
            c.poll(0.05)
            if rng.random() < 0.1:
                kind = rng.choice(["drive", "approach", "align"])
                m = c.call(DRIVE, drive(0.2, 0)) if kind == "drive" else \
                    c.call(APPROACH, struct.pack("<d", 0.6)) if kind == "approach" else c.call(ALIGN)
                tries.append((round(time.monotonic() - tm, 2), kind, describe(m) if m else None))
        obs.poll(0.05)
        st = obs.status()
        tel = [parse_telem(m.p) for m in obs.log[n_before:] if m.type == TELEM]
        turned = len({(t["left_counts"], t["right_counts"]) for t in tel}) > 1
        accepted = [t for t in tries if t[2] and t[2].startswith("Ack")]
        evs = [(e_[0], e_[2], e_[3][:90]) for e_ in obs.events() if e_[0] == "fault_latched"]
        rr = c.call(RESET, b"\x00")
        # after the Reset: 3 s of Drives (arm_stop_timeout_s is 2): the wheels must not turn
        # while the arm has not reported idle
        n2 = len(obs.log)
        t2 = time.monotonic()
        after = []
        while time.monotonic() - t2 < 3.0:
            m = c.call(DRIVE, drive(0.2, 0))
            after.append(describe(m) if m else None)
            c.poll(0.1)
        c.call(STOP)
        obs.poll(0.05)
        st2 = obs.status()
        tel2 = [parse_telem(m.p) for m in obs.log[n2:] if m.type == TELEM]
        turned2 = len({(t["left_counts"], t["right_counts"]) for t in tel2}) > 1
        ok_after = [a for a in after if a and a.startswith("Ack")]
        if turned2 and mode in ("hang", "unplug", "stuckbusy"):
            probs.append("wheels turned after Reset while the arm never reported idle: %s" % ok_after[:2])
        say("     after Reset: Drives acked %d of %d (first refusal %s, last %s); turned=%s; fault now %d" % (
            len(ok_after), len(after), next((a for a in after if a and a.startswith("Error")), None),
            after[-1], turned2, st2["fault"]))
        if turned:
            probs.append("wheels turned after the arm misbehaved")
        if accepted:
            probs.append("motion accepted: %s" % accepted)
        arm_idle = arm.phase == "IDLE" and mode not in ("hang", "unplug")
        line_ = "trial %d %s +%.2fs after the task: engage=%s; fault=%d state=%s arm=%s evs=%s; tries=%s; Reset->%s (fault after %d)" % (
            trial, mode, delay, describe(e) if e else None, st["fault"], st["state"], st["arm"],
            evs[:3], tries[:3], describe(rr) if rr else None, st2["fault"])
        say(("OK   " if not probs else "FAIL ") + line_ + (" :: %s" % probs if probs else ""))
        if probs:
            fails.append(line_)
        c.close()
        obs.close()
    except Exception as ex:
        say("ERROR trial %d %s: %r" % (trial, mode, ex))
        fails.append("trial %d exception %r" % (trial, ex))
    finally:
        rc = d.stop()
        arm.close()
        lines = [l for l in d.log().splitlines() if "arm" in l.lower() and ("warn" in l or "error" in l)]
        for l in lines[:6]:
            say("     log:", l[:200])
        if rc != 0:
            say("     ajard exit %s" % rc)
say("RESULT seed=%d trials=%d fails=%d" % (seed, trials, len(fails)))
