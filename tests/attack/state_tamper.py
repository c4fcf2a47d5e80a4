#!/usr/bin/env python3
"""Item 5 widened: EmergencyStop, SIGTERM, then the state file is damaged in various ways, restart:
a fault latched? Drive refused? Then a second clean restart without Reset: still latched?

Usage: state_tamper.py [kinds...]   (default: all)
"""
import os
import shutil
import struct
import sys
import time

from ajarwire import *

KINDS = ["flipfault", "flipcrc", "truncate", "empty", "garbage", "directory", "delete",
         "cleanmark0", "format1", "tmpleftover", "unreadable-perm"]
kinds = sys.argv[1:] or KINDS
fails = []


def check(d, label):
    c = d.conn(0)
    st = c.status()
    r = c.call(DRIVE, drive(0.1, 0.0))
    time.sleep(0.3)
    st2 = c.status()
    moved = abs(st2["odo_x"]) > 1e-4
    good = st["fault"] != 0 and not ok(r) and not moved
    line = "%s: fault=%d state=%s Drive->%s moved=%s" % (label, st["fault"], st["state"], r, moved)
    say(("  OK " if good else "  FAIL ") + line)
    if not good:
        fails.append(line)
    c.call(STOP)
    c.close()


for kind in kinds:
    d = Daemon({"drivers.kind": "mock"}, name="tamper")
    d.start()
    c = d.conn(0)
    measure_all(c, plane=False)
    c.call(DRIVE, drive(0.2, 0.0))
    time.sleep(0.1)
    e = c.call(ESTOP)
    c.close()
    d.stop()
    f = os.path.join(d.state_dir, "ajard.state")
    text = open(f, "rb").read()
    if kind == "flipfault":
        text = text.replace(b"fault 513", b"fault 0  ")
    elif kind == "flipcrc":
        text = text.replace(b"fault 513", b"fault 000")
    elif kind == "truncate":
        text = text[:len(text) // 2]
    elif kind == "empty":
        text = b""
    elif kind == "garbage":
        text = os.urandom(200)
    elif kind == "cleanmark0":
        text = text.replace(b"clean_shutdown 1", b"clean_shutdown 0")
    elif kind == "format1":
        text = text.replace(b"ajar-state 2", b"ajar-state 1")
    if kind == "directory":
        os.unlink(f)
        os.mkdir(f)
    elif kind == "delete":
        os.unlink(f)
    elif kind == "tmpleftover":
        open(f + ".tmp", "wb").write(b"ajar-state 2\nclean_shutdown 1\nfault 0\n")
    elif kind == "unreadable-perm":
        os.chmod(f, 0)
    else:
        open(f, "wb").write(text)
    say("%s: estop %s; state file tampered (%s)" % (kind, e, kind))
    try:
        d.start()
    except RuntimeError as ex:
        say("  start refused: %s" % str(ex)[-300:])
        if kind == "directory":
            shutil.rmtree(f)
            open(f, "w").close()
        continue
    check(d, kind + " after restart")
    d.stop()
    d.start()
    check(d, kind + " after a second restart, no Reset")
    d.stop()
say("RESULT fails=%d" % len(fails))
for l in fails:
    say("  ", l)
