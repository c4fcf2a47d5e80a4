"""Minimal Ajar wire-protocol client and ajard launcher for adversarial tests (docs/protocol.md).

Raw sockets on purpose: several frames in one write, duplicates, bad frames, withheld bytes.
"""
import os
import random
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.environ.get("AJAR_BUILD", os.path.join(ROOT, "build"))
AJARD = os.environ.get("AJARD", os.path.join(BUILD, "daemon", "ajard"))

_T = []
for i in range(256):
    c = i
    for _ in range(8):
        c = (c >> 1) ^ (0x82F63B78 if c & 1 else 0)
    _T.append(c)


def crc32c(data):
    c = 0xFFFFFFFF
    for b in data:
        c = _T[(c ^ b) & 0xFF] ^ (c >> 8)
    return c ^ 0xFFFFFFFF


HELLO, PING, WIDTH, HANDLE, PLANE, CONTACT = 0x101, 0x102, 0x110, 0x111, 0x112, 0x113
ALIGN, ENGAGE, DRIVE, APPROACH = 0x120, 0x121, 0x122, 0x123
STOP, ESTOP, RESET, STATUS, SUBSCRIBE, MODEL = 0x130, 0x131, 0x132, 0x140, 0x141, 0x142
WELCOME, PONG, ACK, ERROR, EVENT, STATUSR, TELEM = 0x201, 0x202, 0x203, 0x204, 0x205, 0x206, 0x207
STATES = ["awaiting_width", "awaiting_handle", "awaiting_plane", "ready_to_align", "aligning",
          "aligned", "ready_to_engage", "engaging", "engaged", "fault"]
EVENTS = ["state_changed", "motion_started", "motion_finished", "motion_stopped", "fault_latched",
          "fault_cleared", "control_changed"]
ARM = ["disconnected", "idle", "busy", "done", "fault"]


def frame(mtype, payload=b"", rid=0, flags=0, minor=1, corrupt_crc=False):
    hdr = struct.pack("<IBBHHII", 0x52414A41, 1, minor, mtype, flags, rid, len(payload))
    c = crc32c(hdr + payload)
    if corrupt_crc:
        c ^= 1
    return hdr + struct.pack("<I", c) + payload


def s32(text):
    b = text.encode()[:32]
    return bytes([len(b)]) + b + b"\0" * (32 - len(b))


def hello(role=0, take_over=False, instance=0, name="attack"):
    return struct.pack("<BBBBQ", 1, 1, role, 1 if take_over else 0, instance) + s32(name)


def pt(x, y, z, fr=1):
    return struct.pack("<Bddd", fr, x, y, z)


def drive(v, w):
    return struct.pack("<dd", v, w)


# A door 1.0 m ahead (base frame), 0.9 m wide, hinge on the left.
WIDTH_PTS = pt(1.0, 0.45, 0.9) + pt(1.0, -0.45, 0.9)
HANDLE_PTS = pt(1.0, -0.30, 0.9) + pt(1.0, -0.40, 0.9)


def plane_pts(yaw_slope=0.1, x0=1.0):
    ps = [(0.3, 0.5), (-0.3, 0.5), (0.0, 1.2), (0.2, 1.0)]
    return bytes([len(ps)]) + b"".join(pt(x0 + yaw_slope * y, y, z) for y, z in ps)


CONTACT_PT = pt(0.9, -0.35, 0.9)


class Msg:
    def __init__(self, mtype, rid, payload):
        self.type, self.rid, self.p = mtype, rid, payload
        self.t = time.monotonic()

    def __repr__(self):
        return "<%s>" % describe(self)


def parse_error(p):
    code, off = struct.unpack_from("<HH", p, 0)
    fl = p[5:5 + p[4]].decode(errors="replace")
    msg = p[38:38 + p[37]].decode(errors="replace")
    return code, off, fl, msg


def parse_event(p):
    kind, st, fault, t = struct.unpack_from("<BBHQ", p, 0)
    return EVENTS[kind], STATES[st], fault, p[13:13 + p[12]].decode(errors="replace")


def parse_telem(p):
    d = {}
    d["t_ns"], st, mv = struct.unpack_from("<QBB", p, 0)
    d["state"], d["moving"] = STATES[st], bool(mv)
    d["left_rad"], d["right_rad"], d["left_counts"], d["right_counts"], d["yaw"] = \
        struct.unpack_from("<ddqqd", p, 10)
    d["arm"] = ARM[p[50]]
    mb = 87
    d["odo_x"], d["odo_y"] = struct.unpack_from("<dd", p, mb)
    d["cmd_v"], d["cmd_w"] = struct.unpack_from("<dd", p, mb + 44)
    return d


def parse_status(p):
    d = {"state": STATES[p[0]], "fault": struct.unpack_from("<H", p, 1)[0],
         "restored": bool(p[3]), "controller": bool(p[4]),
         "has_width": bool(p[7]), "has_handle": bool(p[65]), "has_plane": bool(p[123]),
         "has_contact": bool(p[205])}
    d["card"], d["arm_link"], d["arm"] = p[246], p[247], ARM[p[248]]
    d["odo_x"], d["odo_y"] = struct.unpack_from("<dd", p, 285)
    d["yaw"] = struct.unpack_from("<d", p, 238)[0]
    return d


def describe(m):
    if m.type == ACK:
        a, st = struct.unpack_from("<HB", m.p, 0)
        return "Ack(%#x rid=%d %s)" % (a, m.rid, STATES[st])
    if m.type == ERROR:
        return "Error(rid=%d %d %s: %s)" % ((m.rid,) + parse_error(m.p)[0:1] + parse_error(m.p)[2:])
    if m.type == EVENT:
        return "Event%s" % (parse_event(m.p),)
    if m.type == WELCOME:
        return "Welcome(role=%d)" % m.p[2]
    if m.type == TELEM:
        return "Telem(%s)" % parse_telem(m.p)
    if m.type == STATUSR:
        return "Status(%s)" % parse_status(m.p)
    return "Msg(%#x rid=%d)" % (m.type, m.rid)


class Conn:
    def __init__(self, port, host="127.0.0.1", sock=None, timeout=5.0):
        self.s = sock or socket.create_connection((host, port), timeout=timeout)
        self.s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.buf = b""
        self.rid = 100
        self.log = []
        self.closed = False

    def send(self, data):
        self.s.sendall(data)

    def req(self, mtype, payload=b"", rid=None, **kw):
        if rid is None:
            self.rid += 1
            rid = self.rid
        return frame(mtype, payload, rid, **kw), rid

    def cmd(self, mtype, payload=b"", rid=None, **kw):
        f, rid = self.req(mtype, payload, rid, **kw)
        self.send(f)
        return rid

    def _pump(self, timeout):
        if self.closed:
            return False
        r, _, _ = select.select([self.s], [], [], max(0.0, timeout))
        if not r:
            return False
        try:
            data = self.s.recv(65536)
        except (ConnectionResetError, OSError):
            data = b""
        if not data:
            self.closed = True
            return False
        self.buf += data
        while len(self.buf) >= 22:
            magic, ma, mi, t, fl, rid, ln, crc = struct.unpack_from("<IBBHHIII", self.buf, 0)
            if len(self.buf) < 22 + ln:
                break
            m = Msg(t, rid, self.buf[22:22 + ln])
            self.buf = self.buf[22 + ln:]
            self.log.append(m)
        return True

    def poll(self, timeout=0.0):
        end = time.monotonic() + timeout
        while True:
            got = self._pump(max(0.0, end - time.monotonic()))
            if not got and time.monotonic() >= end:
                return

    def wait(self, pred, timeout=5.0):
        """Wait for a message satisfying pred among those not yet consumed; returns it or None."""
        end = time.monotonic() + timeout
        idx = getattr(self, "_seen", 0)
        while True:
            for i in range(idx, len(self.log)):
                if pred(self.log[i]):
                    return self.log[i]
            idx = len(self.log)
            if time.monotonic() >= end or self.closed:
                return None
            self._pump(min(0.05, max(0.0, end - time.monotonic())))

    def reply(self, rid, timeout=5.0):
        return self.wait(lambda m: m.rid == rid and m.type in (ACK, ERROR, WELCOME, STATUSR, PONG),
                         timeout)

    def call(self, mtype, payload=b"", timeout=5.0, **kw):
        rid = self.cmd(mtype, payload, **kw)
        return self.reply(rid, timeout)

    def greet(self, role=0, take_over=False, instance=0):
        m = self.call(HELLO, hello(role, take_over, instance))
        assert m is not None and m.type == WELCOME, "no Welcome: %r" % m
        return m

    def status(self):
        m = self.call(STATUS)
        return parse_status(m.p) if m is not None and m.type == STATUSR else None

    def events(self):
        return [parse_event(m.p) for m in self.log if m.type == EVENT]

    def telems(self):
        return [parse_telem(m.p) for m in self.log if m.type == TELEM]

    def close(self):
        try:
            self.s.close()
        except OSError:
            pass


def ok(m):
    return m is not None and m.type == ACK


def err(m):
    return parse_error(m.p)[0] if m is not None and m.type == ERROR else None


BASE_CONFIG = open(os.path.join(ROOT, "config", "ajard.yaml")).read()


def make_config(overrides):
    """overrides: {"drive.max_linear_speed_m_s": 0.02, ...} applied by textual substitution on
    config/ajard.yaml (only keys that appear there), or appended sections (extra_yaml). A key is
    its dotted path ("recorder.directory") or, when that leaf is unique in the file, the leaf alone
    ("port")."""
    import re
    lines = BASE_CONFIG.split("\n")
    extra = overrides.pop("__extra__", "")

    def paths():
        stack = []  # (indent, name)
        for i, line in enumerate(lines):
            m = re.match(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*):", line)
            if not m:
                continue
            ind = len(m.group(1))
            while stack and stack[-1][0] >= ind:
                stack.pop()
            stack.append((ind, m.group(2)))
            yield i, ".".join(n for _, n in stack), m.group(1), m.group(2)

    for k, v in overrides.items():
        if k == "drivers.kind":
            k = "drivers.kind"
        hits = [(i, ind, leaf) for i, path, ind, leaf in paths() if path == k]
        if not hits and "." not in k:
            hits = [(i, ind, leaf) for i, path, ind, leaf in paths() if leaf == k]
        assert len(hits) == 1, "key %s found %d times" % (k, len(hits))
        i, ind, leaf = hits[0]
        lines[i] = "%s%s: %s" % (ind, leaf, v)
    return "\n".join(lines) + "\n" + extra


class Daemon:
    def __init__(self, overrides=None, state_dir=None, env=None, name="attack"):
        self.dir = tempfile.mkdtemp(prefix="ajar-%s-" % name)
        self.state_dir = state_dir or os.path.join(self.dir, "state")
        self.overrides = dict(overrides or {})
        self.env = dict(os.environ)
        self.env.update(env or {})
        self.p = None
        self.port = None
        self.runs = 0

    def write_config(self, overrides=None):
        o = dict(self.overrides)
        o.update(overrides or {})
        o.setdefault("network.port", 0)
        o.setdefault("state.directory", self.state_dir)
        o.setdefault("recorder.directory", os.path.join(self.dir, "recordings"))
        self.cfg = os.path.join(self.dir, "ajard.yaml")
        with open(self.cfg, "w") as f:
            f.write(make_config(o))

    def start(self, overrides=None, wait=True):
        self.write_config(overrides)
        pf = os.path.join(self.dir, "port")
        if os.path.exists(pf):
            os.unlink(pf)
        self.runs += 1
        self.logpath = os.path.join(self.dir, "ajard.%d.log" % self.runs)
        self.logf = open(self.logpath, "w")
        self.p = subprocess.Popen([AJARD, "--config", self.cfg, "--port-file", pf],
                                  stdout=self.logf, stderr=subprocess.STDOUT, env=self.env)
        end = time.monotonic() + 15
        while time.monotonic() < end:
            if os.path.exists(pf) and open(pf).read().strip():
                self.port = int(open(pf).read().strip())
                return self
            if self.p.poll() is not None:
                raise RuntimeError("ajard exited %s: %s" % (self.p.returncode,
                                                             open(self.logpath).read()[-2000:]))
            time.sleep(0.02)
        raise RuntimeError("ajard did not start")

    def log(self):
        return open(self.logpath).read()

    def signal(self, sig):
        self.p.send_signal(sig)

    def kill9(self):
        self.p.send_signal(signal.SIGKILL)
        self.p.wait()

    def stop(self, timeout=15):
        if self.p and self.p.poll() is None:
            self.p.send_signal(signal.SIGTERM)
            try:
                self.p.wait(timeout)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        return self.p.returncode if self.p else None

    def conn(self, role=None, take_over=False, instance=0):
        c = Conn(self.port)
        if role is not None:
            c.greet(role, take_over, instance)
        return c


def measure_all(c, plane=True, contact=False, yaw_slope=0.1):
    out = [c.call(WIDTH, WIDTH_PTS), c.call(HANDLE, HANDLE_PTS)]
    if plane:
        out.append(c.call(PLANE, plane_pts(yaw_slope)))
    if contact:
        out.append(c.call(CONTACT, CONTACT_PT))
    return out


def engage_ready(c):
    """Measure everything, align (waiting for motion_finished), set the contact point: the
    procedure at ready_to_engage. Returns the SetContactPoint reply."""
    measure_all(c, plane=True)
    c.call(ALIGN)
    c.wait(lambda m: m.type == EVENT and parse_event(m.p)[0] == "motion_finished", 15)
    return c.call(CONTACT, CONTACT_PT)


def use_tls(pki, identities, extra=()):
    """Every Daemon started from now on serves mutual TLS with the scripts/make-certs PKI in pki
    (ajard.crt/.key, ca.crt, ca.crl); identities: [(cn, role)]; extra: more network.tls keys,
    ("unlisted: refuse", ...)."""
    global BASE_CONFIG
    ident = "".join("\n      - {cn: %s, role: %s}" % i for i in identities)
    more = "".join("    %s\n" % line for line in extra)
    BASE_CONFIG = BASE_CONFIG.replace("network:\n", """network:
  tls:
    enabled: true
    certificate: %s/ajard.crt
    private_key: %s/ajard.key
    ca: %s/ca.crt
    crl: %s/ca.crl
%s    identities:%s
""" % (pki, pki, pki, pki, more, ident), 1)


def say(*a):
    print(*a, flush=True)


class Campaign:
    """A seeded attack campaign (races.py, races2.py): argv[1] the seed (default: the time),
    argv[2] the rounds; `rng` draws every random choice; a daemon on sim drivers is started;
    `verdict` counts each check per name, `report` prints the counts and the RESULT line."""

    def __init__(self, name, default_rounds, echo_ok=False):
        self.seed = int(sys.argv[1]) if len(sys.argv) > 1 else int(time.time())
        self.rounds = int(sys.argv[2]) if len(sys.argv) > 2 else default_rounds
        self.rng = random.Random(self.seed)
        say("seed", self.seed)
        self.daemon = Daemon({"drivers.kind": "sim"}, name=name)
        self.daemon.start()
        self.fails = []
        self.counts = {}
        self.echo_ok = echo_ok

    def verdict(self, name, good, detail):
        self.counts.setdefault(name, [0, 0])
        self.counts[name][0 if good else 1] += 1
        if good and self.echo_ok:
            say("OK  ", name, "::", detail)
        if not good:
            self.fails.append("%s: %s" % (name, detail))
            say("FAIL", name, "::", detail)

    def report(self, width=55):
        for k, v in self.counts.items():
            say("%-*s ok %d fail %d" % (width, k, v[0], v[1]))
        say("RESULT seed=%d fails=%d" % (self.seed, len(self.fails)))
