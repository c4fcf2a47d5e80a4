#!/usr/bin/env python3
"""Checks ajarctl --json output of procedure.txt: every line is one JSON object; the documented
fields are present, with the right types and values."""
import json
import math
import sys

lines = [l for l in sys.stdin.read().splitlines() if l.strip()]
objs = []
for n, line in enumerate(lines, 1):
    try:
        objs.append(json.loads(line))
    except json.JSONDecodeError as e:
        sys.exit(f"line {n} is not JSON ({e}): {line}")

def fail(msg):
    sys.exit("FAIL: " + msg + "\n" + "\n".join(lines))

def number(o, key):
    v = o.get(key)
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        fail(f"{o.get('command')}: {key} is not a finite number: {v!r}")
    return v

def left_right(o, key, kind):
    """The wire's left_KEY and right_KEY (docs/protocol.md section 10: wire names)."""
    v = {side: o.get(f"{side}_{key}") for side in ("left", "right")}
    for side in ("left", "right"):
        if not isinstance(v[side], kind) or isinstance(v[side], bool):
            fail(f"{o.get('command')}: {side}_{key} has the wrong type: {v[side]!r}")
    return v

def vec3(o, key):
    """A wire Vec3: {x, y, z}."""
    v = o.get(key)
    if not isinstance(v, dict) or list(v) != ["x", "y", "z"]:
        fail(f"{o.get('command')}: {key} must be {{x, y, z}}: {v!r}")
    return v

for o in objs:
    keys = ("type",) if o.get("type") in ("event", "telemetry") else ("type", "command", "ok")
    for key in keys:
        if key not in o:
            fail(f"object without {key}: {o}")

replies = [o for o in objs if o["type"] not in ("event", "telemetry")]
by_command = {}
for o in replies:
    by_command.setdefault(o.get("command"), []).append(o)

w = by_command["measure_width"][0]
if not w["ok"] or abs(number(w, "length_m") - 0.9) > 1e-9 or w["direction"] != "CCW":
    fail(f"width: {w}")
vec3(w, "p1_base_m")
w2 = by_command["measure_width"][1]
if not w2["ok"] or abs(w2["length_m"] - 0.9) > 1e-9 or w2["direction"] != "CCW":
    fail(f"camera-frame width: {w2}")
h = by_command["measure_handle"][0]
if not h["ok"] or abs(number(h, "length_m") - 0.12) > 1e-9 or h["direction"] not in ("CW", "CCW"):
    fail(f"handle: {h}")
p = by_command["measure_plane"][0]
if not p["ok"] or abs(number(p, "yaw_deviation_rad") + 0.0277) > 0.001:
    fail(f"plane: {p}")
wa = left_right(p, "wheel_rad", float)
wc = left_right(p, "counts", int)
vec3(p, "normal")
if not (wa["left"] > 0 > wa["right"]):
    fail("a CW turn rolls the left wheel forward and the right wheel back")
bad = by_command["measure_plane"][1]
if bad["ok"] or bad["type"] != "error" or bad["error"]["code"] != "POINTS_COLLINEAR":
    fail(f"collinear plane: {bad}")
for key in ("code", "offending_type", "field", "message"):
    if not isinstance(bad["error"].get(key), str):
        fail(f"error.{key} missing")
align = [o for o in by_command["align"] if o["type"] == "align_result"]
if len(align) != 1 or not align[0]["ok"] or align[0]["state"] != "aligned":
    fail(f"align: {by_command['align']}")
if abs(number(align[0], "yaw_turned_rad") + 0.0277) > 0.002:
    fail(f"align turned {align[0]['yaw_turned_rad']}")
c = by_command["contact"][0]
cb = vec3(c, "contact_base_m")
if not c["ok"] or abs(cb["x"] - 0.8) > 1e-9:
    fail(f"contact: {c}")
number(c, "reach_margin_m")
e = [o for o in by_command["engage"] if o["type"] == "engage_result"]
if len(e) != 1 or not e[0]["ok"] or e[0]["state"] != "engaged":
    fail(f"engage: {by_command['engage']}")
st = by_command["status"][1]["status"]
if st["state"] != "engaged" or not st["has_width"] or not st["has_plane"] or "width" not in st:
    fail(f"status: {st}")
stats = [o for o in by_command["ping"] if o["type"] == "ping_stats"][0]
for key in ("min_ms", "avg_ms", "max_ms", "p99_ms"):
    number(stats, key)
if not stats["min_ms"] <= stats["avg_ms"] <= stats["max_ms"]:
    fail("ping statistics out of order")
events = [o for o in objs if o["type"] == "event"]
if not any(ev["kind"] == "motion_finished" for ev in events):
    fail("no motion_finished event shown during align")
print(f"ok: {len(objs)} JSON objects checked")
