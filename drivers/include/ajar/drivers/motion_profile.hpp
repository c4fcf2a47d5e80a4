// Closed-form one-axis motion profiles, shared by the card simulator (drivers/cardsim) and the
// mock card (mock_card.cpp): a motion is up to four phases of constant acceleration from a start
// state, evaluated exactly at any time (integer nanoseconds since its start), so that sampling
// at any rate gives the same trajectory and a time jump costs O(1). Header-only, noexcept, pure.
//
// Units are the card's: positions in counts, velocities in counts/ms (signed), accelerations in
// counts/ms^2; durations in ms (double), instants in ns (integer).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace ajar::drivers::profile {

struct Phase {
  double duration_ms = 0;  // may be +infinity (a jog that cruises until told otherwise)
  double acc = 0;          // signed, counts/ms^2
};

struct Motion {
  std::int64_t t0_ns = 0;
  double p0 = 0, v0 = 0;
  Phase phases[4];
  int count = 0;
  bool exact_end = false;  // a trapezoid ends exactly on its target
  double end = 0;

  void add(double duration_ms, double acc) noexcept {
    if (duration_ms > 0 && count < 4) phases[count++] = Phase{duration_ms, acc};
  }
};

struct Sample {
  double position = 0;
  double velocity = 0;
  bool done = false;  // every phase has run: the axis rests at `position`
};

inline double sign(double v) noexcept {
  return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
}

inline Sample sample(const Motion& m, std::int64_t now_ns) noexcept {
  double t = static_cast<double>(std::max<std::int64_t>(0, now_ns - m.t0_ns)) / 1e6;
  double p = m.p0;
  double v = m.v0;
  for (int i = 0; i < m.count; ++i) {
    const Phase& ph = m.phases[i];
    if (t < ph.duration_ms) return Sample{p + v * t + 0.5 * ph.acc * t * t, v + ph.acc * t, false};
    p += v * ph.duration_ms + 0.5 * ph.acc * ph.duration_ms * ph.duration_ms;
    v += ph.acc * ph.duration_ms;
    t -= ph.duration_ms;
  }
  return Sample{m.exact_end ? m.end : p, 0.0, true};
}

// Decelerates from velocity v to rest at `dec` (> 0).
inline Motion plan_stop(std::int64_t t0_ns, double p, double v, double dec) noexcept {
  Motion m;
  m.t0_ns = t0_ns;
  m.p0 = p;
  m.v0 = v;
  m.add(std::fabs(v) / dec, -sign(v) * dec);
  return m;
}

// A trapezoidal move to `goal` from position p at velocity v: an axis moving away from the goal
// first decelerates to rest; then it accelerates at `acc` (or decelerates at `dec` from above
// vmax) to vmax or a triangular peak, cruises, and decelerates at `dec` to land on the goal. An
// axis already too fast to stop within the remaining distance at `dec` decelerates harder, just
// enough to land on the goal (the card would overshoot and return; the simplification is
// documented). vmax, acc, dec > 0.
inline Motion plan_trap(std::int64_t t0_ns, double p, double v, double goal, double vmax,
                        double acc, double dec) noexcept {
  Motion m;
  m.t0_ns = t0_ns;
  m.p0 = p;
  m.v0 = v;
  m.exact_end = true;
  m.end = goal;
  double here = p;
  double dir = sign(goal - here);
  if (v != 0 && sign(v) != dir) {  // moving away from the goal (or sitting on it): stop first
    m.add(std::fabs(v) / dec, -sign(v) * dec);
    here += v * std::fabs(v) / (2 * dec);
    v = 0;
    dir = sign(goal - here);
  }
  const double distance = std::fabs(goal - here);
  if (distance == 0) return m;
  const double u0 = std::fabs(v);
  if (u0 > 0 && u0 * u0 / (2 * dec) >= distance) {
    m.add(2 * distance / u0, -dir * u0 * u0 / (2 * distance));
    return m;
  }
  if (u0 > vmax) {
    const double d1 = (u0 * u0 - vmax * vmax) / (2 * dec);
    const double d3 = vmax * vmax / (2 * dec);
    m.add((u0 - vmax) / dec, -dir * dec);
    m.add((distance - d1 - d3) / vmax, 0);
    m.add(vmax / dec, -dir * dec);
    return m;
  }
  const double d_acc = (vmax * vmax - u0 * u0) / (2 * acc);
  const double d_dec = vmax * vmax / (2 * dec);
  if (d_acc + d_dec <= distance) {
    m.add((vmax - u0) / acc, dir * acc);
    m.add((distance - d_acc - d_dec) / vmax, 0);
    m.add(vmax / dec, -dir * dec);
  } else {
    const double peak = std::sqrt((2 * acc * dec * distance + dec * u0 * u0) / (acc + dec));
    m.add((peak - u0) / acc, dir * acc);
    m.add(peak / dec, -dir * dec);
  }
  return m;
}

// Velocity mode (jog): from velocity v to the signed target velocity `target` -- speeding up at
// `acc`, slowing down at `dec`, through rest when the sign changes -- then cruising at `target`
// until told otherwise (a target of 0 ends at rest). acc, dec > 0.
inline Motion plan_jog(std::int64_t t0_ns, double p, double v, double target, double acc,
                       double dec) noexcept {
  Motion m;
  m.t0_ns = t0_ns;
  m.p0 = p;
  m.v0 = v;
  if (v * target < 0) {  // reverse: slow down to rest first
    m.add(std::fabs(v) / dec, -sign(v) * dec);
    v = 0;
  }
  if (std::fabs(target) > std::fabs(v)) {
    m.add((std::fabs(target) - std::fabs(v)) / acc, sign(target) * acc);
  } else if (std::fabs(target) < std::fabs(v)) {
    m.add((std::fabs(v) - std::fabs(target)) / dec, -sign(v) * dec);
  }
  if (target != 0) m.add(std::numeric_limits<double>::infinity(), 0);
  return m;
}

}  // namespace ajar::drivers::profile
