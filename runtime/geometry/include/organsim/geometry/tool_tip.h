// The end of a tool: a rigid capsule, a hemisphere of radius R on a shaft of
// the same radius (a laparoscopic probe's blunt end: R = 2.5 mm). The tool's
// tip is the capsule's foremost point; the hemisphere's centre lies R behind
// it along the shaft. R = 0 is a point. A tool touches the organ where its
// hemisphere rests on the surface (seat_on). docs/realtime.md#contact-rule says how every
// deformation model holds the organ with it. Units: metres.
#pragma once

#include <algorithm>
#include <cmath>

#include <cstddef>

#include <Eigen/Core>

#include "organsim/model/organ_model.h"

namespace organsim::geometry {

struct ToolTip {
  double radius = 0.0;                             ///< m; 0: a point tool
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();  ///< unit, from the tip towards the handle
  double shaft_length = 0.30;                      ///< m of shaft behind the hemisphere that can touch
  Eigen::Vector3d seat = Eigen::Vector3d::Zero();  ///< m: the foremost point at first touch, from the touched point

  /// The tip of radius `radius` (m) touching a surface point of outward unit
  /// normal `normal`, its shaft along `shaft` (from the tip towards the
  /// handle; any length) or, where that is zero or not finite, along the
  /// normal, and seated there (seat_on). Every place a tool touches the organ
  /// (the engine's contacts, the static presses, the Python module) makes its tip here.
  static ToolTip touching(double radius, const Eigen::Vector3d& shaft, const Eigen::Vector3d& normal,
                          double shaft_length = 0.30) noexcept {
    ToolTip tip;
    tip.radius = radius;
    tip.shaft_length = shaft_length;
    tip.axis = shaft.squaredNorm() > 0.0 && shaft.allFinite() ? Eigen::Vector3d(shaft.normalized()) : normal;
    tip.seat_on(normal);
    return tip;
  }

  /// Whether `radius` (m) is one a tip may have: finite and ≥ 0 (0: a point tool).
  static bool valid_radius(double radius) noexcept { return radius >= 0.0 && std::isfinite(radius); }

  /// Seats the tip at a touched surface point of outward unit normal
  /// `normal`: the hemisphere rests tangent to the surface there (its centre
  /// R along the normal), so a tool tilted θ from the normal begins outside
  /// the organ instead of with its hemisphere's side R(1 − cos θ) inside it,
  /// which the first step would have to push out at once. A shaft pointing
  /// into the organ is not seated.
  void seat_on(const Eigen::Vector3d& normal) noexcept {
    seat = axis.dot(normal) > 0.0 ? Eigen::Vector3d(radius * (normal - axis)) : Eigen::Vector3d::Zero();
  }

  bool is_point() const noexcept { return !(radius > 0.0); }

  /// Where `point` lies against the capsule whose foremost point is `tip`:
  /// its distance outside the capsule's surface (m, negative inside) and the
  /// surface's outward unit normal nearest it (radially away from the axis;
  /// along −axis for a point on the axis below the hemisphere's centre).
  double signed_distance(const Eigen::Vector3d& tip, const Eigen::Vector3d& point,
                         Eigen::Vector3d& normal) const noexcept {
    const Eigen::Vector3d centre = tip + radius * axis;
    const double along = std::clamp((point - centre).dot(axis), 0.0, shaft_length);
    const Eigen::Vector3d radial = point - (centre + along * axis);
    const double distance = radial.norm();
    if (distance > 1e-12 * std::max(radius, 1e-3)) {
      normal = radial / distance;
    } else {
      // On the axis: the nearest surface point is the foremost one.
      normal = -axis;
    }
    return distance - radius;
  }

  /// Moves every point inside the capsule whose foremost point is `tip` onto
  /// its surface (along signed_distance's normal); true when one moved.
  bool push_out(const Eigen::Vector3d& tip, model::Point3* points, std::size_t count) const noexcept {
    bool moved = false;
    for (std::size_t v = 0; v < count; ++v) {
      const Eigen::Vector3d x(points[v][0], points[v][1], points[v][2]);
      Eigen::Vector3d normal;
      const double distance = signed_distance(tip, x, normal);
      if (distance >= 0.0) continue;
      const Eigen::Vector3d on = x - distance * normal;
      points[v] = {on[0], on[1], on[2]};
      moved = true;
    }
    return moved;
  }
};

}  // namespace organsim::geometry
