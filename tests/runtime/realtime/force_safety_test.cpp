// The force safety rules every force passes through on its way to a device
// (force_safety.h): clamp to max_force keeping the direction, NaN/Inf replaced
// by zero, the watchdog's linear ramp-down when the simulation stalls, and the
// onset rate limit. The expected values follow the rule in force_safety.cpp:
//   m = min(|F|, max_force)
//   m ×= clamp(1 − (silence − stall_timeout) / ramp_down_time, 0, 1)  when silence > stall_timeout
//   m = min(m, m_previous + onset_rate · max(dt, 0));  output F · m / |F|
// Times, rates and forces are chosen as binary fractions where the result is
// meant to be exact, so that equalities can be asserted without tolerance.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "organsim/realtime/force_safety.h"

namespace organsim::realtime {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// No onset limit: the clamp and the watchdog alone.
SafetyLimits without_onset(double max_force) {
  SafetyLimits limits;
  limits.max_force = max_force;
  limits.onset_rate = 1e12;
  return limits;
}

// |a × b| / (|a| |b|): zero when the two forces are parallel.
double sine_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return a.cross(b).norm() / (a.norm() * b.norm());
}

TEST(ForceSafetyFilter, DefaultsAreTheDocumentedDeviceLimits) {
  const ForceSafety safety;
  EXPECT_EQ(safety.limits().max_force, 3.3);
  EXPECT_EQ(safety.limits().max_stiffness, 1000.0);
  EXPECT_EQ(safety.limits().onset_rate, 40.0);
  EXPECT_EQ(safety.limits().stall_timeout, 0.1);
  EXPECT_EQ(safety.limits().ramp_down_time, 0.2);
  EXPECT_EQ(safety.non_finite_count(), 0u);
  EXPECT_EQ(safety.clamp_count(), 0u);
  EXPECT_EQ(safety.stalled_count(), 0u);
  SafetyLimits limits;
  limits.max_force = 1.25;
  EXPECT_EQ(ForceSafety(limits).limits().max_force, 1.25);  // the limits it was given
}

TEST(ForceSafetyFilter, ClampsToMaxForceKeepingTheDirectionAndCountsEachClamp) {
  ForceSafety safety(without_onset(2.0));
  const Eigen::Vector3d requests[] = {{3.0, 4.0, 0.0}, {0.0, -12.0, 5.0}, {-1e3, 2e3, 3e3}, {1e6, 0.0, -1e6}};
  std::uint64_t expected_clamps = 0;
  for (const Eigen::Vector3d& f : requests) {
    const Eigen::Vector3d out = safety.filter(f, 1.0, 1.0, 1e-3);
    EXPECT_NEAR(out.norm(), 2.0, 1e-14) << f.transpose();
    EXPECT_LT(sine_between(out, f), 1e-14) << f.transpose();  // same line…
    EXPECT_GT(out.dot(f), 0.0);                               // …and the same sense
    EXPECT_EQ(safety.clamp_count(), ++expected_clamps);
  }
  // (3, 4, 0) is 5 N: scaled by exactly 2/5.
  const Eigen::Vector3d out = safety.filter({3.0, 4.0, 0.0}, 1.0, 1.0, 1e-3);
  EXPECT_NEAR(out[0], 1.2, 1e-15);
  EXPECT_NEAR(out[1], 1.6, 1e-15);
  EXPECT_EQ(out[2], 0.0);
  ++expected_clamps;

  // Forces within the limit, including exactly at it, pass unchanged and unclamped.
  for (const Eigen::Vector3d& f :
       {Eigen::Vector3d(0.0, 0.0, 2.0), Eigen::Vector3d(0.5, -1.0, 0.25), Eigen::Vector3d(-1e-9, 0.0, 0.0)}) {
    EXPECT_EQ(safety.filter(f, 1.0, 1.0, 1e-3), f);
    EXPECT_EQ(safety.clamp_count(), expected_clamps);
  }
  EXPECT_EQ(safety.non_finite_count(), 0u);
  EXPECT_EQ(safety.stalled_count(), 0u);
}

TEST(ForceSafetyFilter, NonFiniteInputGivesZeroForceAndIsCounted) {
  ForceSafety safety(without_onset(3.0));
  const Eigen::Vector3d bad[] = {{kNaN, 0.0, 1.0}, {0.0, kInf, 0.0}, {0.0, 0.0, -kInf}, {kNaN, kNaN, kNaN}};
  std::uint64_t expected = 0;
  for (const Eigen::Vector3d& f : bad) {
    EXPECT_EQ(safety.filter(f, 1.0, 1.0, 1e-3), Eigen::Vector3d::Zero());
    EXPECT_EQ(safety.non_finite_count(), ++expected);
  }
  // A non-finite clock is as bad as a non-finite force: the watchdog could not
  // judge it.
  const Eigen::Vector3d f(1.0, 0.0, 0.0);
  EXPECT_EQ(safety.filter(f, kNaN, 1.0, 1e-3), Eigen::Vector3d::Zero());
  EXPECT_EQ(safety.filter(f, 1.0, kInf, 1e-3), Eigen::Vector3d::Zero());
  EXPECT_EQ(safety.filter(f, kInf, 1.0, 1e-3), Eigen::Vector3d::Zero());
  EXPECT_EQ(safety.non_finite_count(), expected + 3);
  EXPECT_EQ(safety.clamp_count(), 0u);  // a replaced force is not also a clamp
  // The next finite force passes again.
  EXPECT_EQ(safety.filter(f, 1.0, 1.0, 1e-3), f);
}

TEST(ForceSafetyFilter, AfterANonFiniteForceTheForceReturnsWithARampNotAKick) {
  SafetyLimits limits;
  limits.onset_rate = 64.0;        // N/s
  const double dt = 1.0 / 1024.0;  // s: 1/16 N per tick
  ForceSafety safety(limits);
  const Eigen::Vector3d f(0.0, 1.0, 0.0);
  double now = 0.0;
  // One tick `dt` later, with a fresh frame.
  auto tick = [&](const Eigen::Vector3d& requested) {
    now += dt;
    return safety.filter(requested, now, now, dt);
  };
  for (int k = 0; k < 40; ++k) tick(f);  // up to full force
  ASSERT_EQ(tick(f).norm(), 1.0);
  EXPECT_EQ(tick({kNaN, 0.0, 0.0}), Eigen::Vector3d::Zero());
  EXPECT_EQ(tick(f).norm(), 0.0625);
  EXPECT_EQ(tick(f).norm(), 0.125);
}

TEST(ForceSafetyFilter, WatchdogRampsDownLinearlyAfterTheStallTimeout) {
  SafetyLimits limits = without_onset(2.0);
  limits.stall_timeout = 0.125;  // s
  limits.ramp_down_time = 0.25;  // s
  ForceSafety safety(limits);
  const Eigen::Vector3d f(0.0, 0.0, -1.0);
  const double last_frame = 10.0;
  // silence → remaining fraction 1 − (silence − 0.125)/0.25, within [0, 1].
  struct Step {
    double silence, magnitude;
    bool stalled;
  };
  const Step steps[] = {
      {0.0, 1.0, false},    {0.125, 1.0, false},  // at the timeout: not yet stalled (strictly longer)
      {0.1875, 0.75, true}, {0.25, 0.5, true},   {0.3125, 0.25, true},
      {0.375, 0.0, true},   {0.5, 0.0, true},    {100.0, 0.0, true},  // gone, and stays gone
  };
  std::uint64_t stalled = 0;
  for (const Step& s : steps) {
    const Eigen::Vector3d out = safety.filter(f, last_frame + s.silence, last_frame, 1e-3);
    EXPECT_EQ(out, f * s.magnitude) << "silence " << s.silence;
    if (s.stalled) ++stalled;
    EXPECT_EQ(safety.stalled_count(), stalled) << "silence " << s.silence;
  }
  // A frame that seems to come from the future (clock skew between loops) is
  // not a stall.
  EXPECT_EQ(safety.filter(f, last_frame, last_frame + 1.0, 1e-3), f);
  EXPECT_EQ(safety.stalled_count(), stalled);
}

TEST(ForceSafetyFilter, WatchdogScalesTheClampedForceAndKeepsItsDirection) {
  // Clamp first, then fade: 8 N clamped to 2 N, half-way down the ramp → 1 N.
  SafetyLimits limits = without_onset(2.0);
  limits.stall_timeout = 0.1;
  limits.ramp_down_time = 0.2;
  ForceSafety safety(limits);
  const Eigen::Vector3d f(0.0, 4.8, 6.4);  // 8 N
  const Eigen::Vector3d out = safety.filter(f, 1.2, 1.0, 1e-3);
  EXPECT_NEAR(out.norm(), 1.0, 1e-12);
  EXPECT_LT(sine_between(out, f), 1e-14);
  EXPECT_EQ(safety.clamp_count(), 1u);
  EXPECT_EQ(safety.stalled_count(), 1u);
  // Intermediate points of the ramp with these (non-binary) constants, against
  // the rule evaluated here.
  for (const double silence : {0.11, 0.15, 0.2, 0.25, 0.29, 0.3, 0.31}) {
    const double fraction = std::clamp(1.0 - (silence - 0.1) / 0.2, 0.0, 1.0);
    EXPECT_NEAR(safety.filter(f, 1.0 + silence, 1.0, 1e-3).norm(), 2.0 * fraction, 1e-12) << silence;
  }
}

TEST(ForceSafetyFilter, TheForceRecoversWhenFramesResume) {
  // Stalled to zero, then fresh frames again: the force comes back, at the
  // onset rate (from what was actually sent), not in one jump.
  SafetyLimits limits;
  limits.max_force = 2.0;
  limits.onset_rate = 64.0;  // N/s
  limits.stall_timeout = 0.125;
  limits.ramp_down_time = 0.25;
  const double dt = 1.0 / 1024.0;  // 1/16 N per tick
  ForceSafety safety(limits);
  const Eigen::Vector3d f(1.0, 0.0, 0.0);
  double now = 0.0, last_frame = 0.0;
  for (int tick = 0; tick < 64; ++tick) {  // fresh frames every tick: up to 1 N
    now += dt;
    last_frame = now;
    safety.filter(f, now, last_frame, dt);
  }
  ASSERT_EQ(safety.filter(f, now, last_frame, dt).norm(), 1.0);
  // The simulation stops publishing; the force loop keeps ticking.
  double during_stall = 1.0;
  while (now - last_frame <= 0.5) {
    now += dt;
    const double m = safety.filter(f, now, last_frame, dt).norm();
    EXPECT_LE(m, during_stall);  // never grows while stalled
    during_stall = m;
  }
  EXPECT_EQ(during_stall, 0.0);
  const std::uint64_t stalled = safety.stalled_count();
  EXPECT_GT(stalled, 0u);
  // Frames resume.
  for (int tick = 1; tick <= 20; ++tick) {
    now += dt;
    last_frame = now;
    EXPECT_EQ(safety.filter(f, now, last_frame, dt).norm(), std::min(1.0, tick * 0.0625)) << tick;
  }
  EXPECT_EQ(safety.stalled_count(), stalled);  // no longer counting stalled ticks
}

TEST(ForceSafetyFilter, OnsetRateLimitsGrowthPerTickButNotDecrease) {
  SafetyLimits limits;
  limits.max_force = 3.0;
  limits.onset_rate = 64.0;        // N/s
  const double dt = 1.0 / 1024.0;  // s: at most 1/16 N more per tick
  ForceSafety safety(limits);
  const Eigen::Vector3d f(0.0, 0.6, 0.8);  // 1 N
  double now = 0.0;
  auto tick = [&](const Eigen::Vector3d& requested, double step) {
    now += std::max(step, 0.0);
    return safety.filter(requested, now, now, step);
  };
  for (int k = 1; k <= 20; ++k) {
    const Eigen::Vector3d out = tick(f, dt);
    EXPECT_NEAR(out.norm(), std::min(1.0, k * 0.0625), 1e-15) << k;  // 16 ticks to full force
    EXPECT_LT(sine_between(out, f), 1e-14);
  }
  // Decrease is immediate…
  EXPECT_EQ(tick(0.25 * f, dt), 0.25 * f);
  // …and growth resumes from what was actually sent (0.25 N), not from 1 N.
  EXPECT_NEAR(tick(f, dt).norm(), 0.3125, 1e-15);
  // A zero request sends zero and restarts the onset from zero.
  EXPECT_EQ(tick(Eigen::Vector3d::Zero(), dt), Eigen::Vector3d::Zero());
  EXPECT_NEAR(tick(f, dt).norm(), 0.0625, 1e-15);
  // The allowed growth is proportional to dt; dt ≤ 0 allows none.
  EXPECT_NEAR(tick(f, 4 * dt).norm(), 0.3125, 1e-15);
  EXPECT_NEAR(tick(f, 0.0).norm(), 0.3125, 1e-15);
  EXPECT_NEAR(tick(f, -1.0).norm(), 0.3125, 1e-15);
  // The onset counts from the clamped magnitude: from max_force the next tick
  // stays at max_force.
  ForceSafety clamped(limits);
  for (int k = 0; k < 100; ++k) clamped.filter(10.0 * f, k * dt, k * dt, dt);
  EXPECT_NEAR(clamped.filter(10.0 * f, 0.1, 0.1, dt).norm(), 3.0, 1e-15);
}

TEST(ForceSafetyFilter, OutputIsAlwaysFiniteWithinMaxForceAndRateLimited) {
  // A long pseudo-random sequence (fixed seed: deterministic) of requests,
  // non-finite values, stalls, clock jitter and odd dt. Whatever comes in,
  // what goes out is finite, at most max_force, and grows by at most
  // onset_rate · dt per tick.
  SafetyLimits limits;
  limits.max_force = 2.5;
  limits.onset_rate = 40.0;
  limits.stall_timeout = 0.05;
  limits.ramp_down_time = 0.1;
  ForceSafety safety(limits);
  std::mt19937 random(20240607);
  std::uniform_real_distribution<double> component(-6.0, 6.0), unit(0.0, 1.0);
  double now = 0.0, last_frame = 0.0, previous = 0.0, stall_end = 0.0;
  std::uint64_t injected = 0;
  for (int tick = 0; tick < 20000; ++tick) {
    const double dt = unit(random) < 0.05 ? -1e-3 : 1e-3 * (0.5 + unit(random));
    now += std::abs(dt);
    if (now >= stall_end) {
      last_frame = now - 0.02 * unit(random);                          // a recent frame, with jitter
      if (unit(random) < 0.002) stall_end = now + 0.3 * unit(random);  // the simulation stops for a while
    }
    Eigen::Vector3d f(component(random), component(random), component(random));
    if (unit(random) < 0.1) f *= std::pow(10.0, 6.0 * unit(random));  // up to a million times too large
    if (unit(random) < 0.01) f.setZero();
    if (unit(random) < 0.01) {
      f[tick % 3] = tick % 2 ? kNaN : -kInf;
      ++injected;
    }
    const Eigen::Vector3d out = safety.filter(f, now, last_frame, dt);
    ASSERT_TRUE(out.allFinite()) << tick;
    ASSERT_LE(out.norm(), limits.max_force * (1.0 + 1e-15)) << tick;
    ASSERT_LE(out.norm() - previous, limits.onset_rate * std::max(dt, 0.0) + 1e-12) << tick;
    if (out.norm() > 0.0) {
      EXPECT_LT(sine_between(out, f), 1e-12) << tick;  // never turned
    }
    previous = out.norm();
  }
  EXPECT_EQ(safety.non_finite_count(), injected);
  EXPECT_GT(safety.clamp_count(), 0u);
  EXPECT_GT(safety.stalled_count(), 0u);
}

TEST(ForceSafety, ClampsToTheDeviceLimitAndNeverPassesNaN) {
  SafetyLimits limits;
  limits.max_force = 2.0;
  limits.onset_rate = 1e9;  // no onset limit here
  ForceSafety safety(limits);
  const Eigen::Vector3d big(3.0, 4.0, 0.0);  // 5 N
  const Eigen::Vector3d out = safety.filter(big, 1.0, 1.0, 1e-3);
  EXPECT_NEAR(out.norm(), 2.0, 1e-12);
  EXPECT_NEAR(out.normalized().dot(big.normalized()), 1.0, 1e-12);  // direction kept
  EXPECT_EQ(safety.clamp_count(), 1u);
  for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    const Eigen::Vector3d f = safety.filter({bad, 0.0, 1.0}, 1.001, 1.0, 1e-3);
    EXPECT_EQ(f, Eigen::Vector3d::Zero());
  }
  EXPECT_EQ(safety.non_finite_count(), 2u);
}

TEST(ForceSafety, OnsetIsRateLimitedSoContactNeverKicks) {
  SafetyLimits limits;
  limits.onset_rate = 40.0;  // N/s
  ForceSafety safety(limits);
  const Eigen::Vector3d step(0.0, 0.0, 2.0);  // a sudden 2 N request
  double previous = 0.0;
  for (int tick = 1; tick <= 100; ++tick) {
    const double magnitude = safety.filter(step, tick * 1e-3, tick * 1e-3, 1e-3).norm();
    EXPECT_LE(magnitude - previous, 40.0 * 1e-3 + 1e-12) << tick;
    previous = magnitude;
  }
  EXPECT_NEAR(previous, 2.0, 1e-12);                                                  // reached after 50 ms
  EXPECT_EQ(safety.filter(Eigen::Vector3d::Zero(), 0.101, 0.101, 1e-3).norm(), 0.0);  // release is immediate
}

TEST(ForceSafety, WatchdogRampsTheForceDownWhenTheSimulationStalls) {
  SafetyLimits limits;
  limits.onset_rate = 1e9;
  limits.stall_timeout = 0.1;
  limits.ramp_down_time = 0.2;
  ForceSafety safety(limits);
  const Eigen::Vector3d f(1.0, 0.0, 0.0);
  const double last_frame = 1.0;
  EXPECT_NEAR(safety.filter(f, 1.05, last_frame, 1e-3).norm(), 1.0, 1e-12);  // fresh enough
  EXPECT_NEAR(safety.filter(f, 1.2, last_frame, 1e-3).norm(), 0.5, 1e-12);   // halfway down the ramp
  EXPECT_NEAR(safety.filter(f, 1.3, last_frame, 1e-3).norm(), 0.0, 1e-12);   // gone
  EXPECT_NEAR(safety.filter(f, 2.0, last_frame, 1e-3).norm(), 0.0, 1e-12);
  EXPECT_GT(safety.stalled_count(), 0u);
}

}  // namespace
}  // namespace organsim::realtime
