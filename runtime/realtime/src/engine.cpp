#include "organsim/realtime/engine.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "organsim/geometry/model_measures.h"
#include "organsim/realtime/friction.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::realtime {
namespace {

SurfaceFrame rest_frame(const organ::Organ& organ) {
  SurfaceFrame frame;
  frame.positions = organ.model().surface_vertices;
  frame.normals.resize(frame.positions.size());
  organ::compute_vertex_normals(organ, frame.positions.data(), frame.normals.data(), 0, frame.positions.size());
  frame.held_point.fill(Eigen::Vector3d::Zero());  // Eigen leaves its vectors unset
  return frame;
}

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

// m: a contact ends when its point is this far outside the tangent plane, so
// that a contact beginning exactly on the surface (a shaft's) is not ended by
// rounding on its first tick. The force there is K times 10 µm: imperceptible.
constexpr double kReleaseMargin = 1e-5;
// m: a refused contact (no beam could be built) is not retried until the tool
// has moved this far.
constexpr double kRetryDistance = 1e-3;
// m: a tool whose pose comes back this far from where it was lost was moved
// while away (removed and placed anew): its contact ends.
constexpr double kMovedWhileLost = 1e-3;
// N: a contact that began above the rest surface ends when the organ would
// pull its tool by more than this (below what a device renders).
constexpr double kPullRelease = 1e-4;
// m: a tip this close inside the deformed surface that has not crossed it
// begins a contact too: the surface moved onto the tool (a bulge of a nearly
// incompressible organ, or the organ pressed against a resting tool).
constexpr double kCaughtDepth = 1e-3;

}  // namespace

Engine::Engine(const organ::Organ& organ, const std::vector<devices::HapticDevice*>& devices,
               const EngineOptions& options)
    : organ_(organ),
      devices_(devices),
      options_(options),
      model_(make_deformation_model(options.model, organ, options.models, std::max<std::size_t>(devices.size(), 1))),
      deformed_tree_(organ.model().surface_vertices, organ.model().surface_triangles),
      moved_mark_(organ.vertex_count(), 0),
      moved_list_(organ.vertex_count()),
      surfaces_(rest_frame(organ)) {
  if (devices.empty() || devices.size() > kMaxTools) throw std::invalid_argument("an engine drives 1 to 16 tools");
  for (std::size_t i = 0; i < devices.size(); ++i)
    if (!geometry::ToolTip::valid_radius(options.tip_radius_of(i)))
      throw std::invalid_argument("a tool's tip radius must be a finite length >= 0");
  for (devices::HapticDevice* d : devices)
    if (d == nullptr) throw std::invalid_argument("a haptic device is missing");
  for (std::size_t i = 0; i < devices.size(); ++i) safety_[i] = ForceSafety(devices[i]->limits());
  if (!(options.friction >= 0.0)) throw std::invalid_argument("the friction coefficient must be >= 0 (or infinity)");
  // Eigen's vectors start uninitialized, even value-initialized in an array.
  for (auto* vectors : {&displacement_, &slip_, &blend_offset_, &fault_force_, &letting_go_, &last_valid_tip_,
                        &previous_tip_, &refused_at_})
    for (Eigen::Vector3d& v : *vectors) v.setZero();
  blend_frame_.fill(-1.0);
  fault_start_.fill(-1.0);
  if (options.tick_records > 0)
    for (std::size_t i = 0; i < devices.size(); ++i) tick_records_[i].allocate(options.tick_records);
}

void Engine::publish_linearization(std::size_t tool) noexcept {
  const ContactLinearization& model = linearizations_[tool];
  ToolContact& contact = contacts_.tools[tool];
  // A contact stiffer than the device can render is softened to its limit.
  contact.stiffness = model.stiffness;
  const double stiffest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(
                              0.5 * (model.stiffness + model.stiffness.transpose()), Eigen::EigenvaluesOnly)
                              .eigenvalues()
                              .maxCoeff();
  const double limit = devices_[tool]->limits().max_stiffness;
  if (stiffest > limit) contact.stiffness *= limit / stiffest;
  contact.reference = model.displacement;
  contact.force = model.force;
}

double Engine::blend_left(std::size_t tool, double now) const noexcept {
  return std::clamp(1.0 - (now - blend_start_[tool]) / options_.deformation_period, 0.0, 1.0);
}

void Engine::force_tick(double now) noexcept {
  contact_frames_.update();
  const ContactFrame& contacts = contact_frames_.read();
  const double dt = previous_tick_ < 0.0 ? options_.force_period : now - previous_tick_;
  previous_tick_ = now;
  // Before the first deformation frame nothing is in contact; the watchdog
  // measures silence from the latest frame once there is one.
  const double last_frame = contacts.time < 0.0 ? now : contacts.time;

  ToolFrame& out = tool_frames_.write_slot();
  out.time = now;
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    devices::ToolPose pose;
    const bool valid = devices_[i]->read_pose(now, pose) && pose.tip.allFinite() && pose.shaft.allFinite();
    out.tips[i] = valid ? pose.tip : Eigen::Vector3d::Zero();
    out.shafts[i] = valid ? pose.shaft : Eigen::Vector3d::Zero();
    out.tip_valid[i] = valid;

    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    bool touching = false, grasp_slipped = false;
    double depth = 0.0;
    const ToolContact& contact = contacts.tools[i];
    // Without a pose the jaws stay as they were.
    const bool jaws = valid ? pose.jaws_closed : jaws_were_closed_[i];
    const bool was_grasped = grasped_[i];
    // A pose lost and found again elsewhere (a tool removed and placed anew,
    // another client on the tool's stream) is another tool: the contact it
    // held ends. One found where it was lost resumes its contact.
    if (contact.active && valid && fault_start_[i] >= 0.0 && (pose.tip - last_valid_tip_[i]).norm() > kMovedWhileLost)
      released_[i] = contact.generation;
    if (valid) last_valid_tip_[i] = pose.tip;
    if (contact.active && released_[i] != contact.generation) {
      if (seen_generation_[i] != contact.generation) {
        seen_generation_[i] = contact.generation;
        ++telemetry_[i].contacts;
        slip_[i].setZero();
        grasped_[i] = false;
      }
      // Jaws that close on a live contact take hold of it; jaws closed
      // before the contact began hold nothing; opening them lets go.
      if (!jaws) {
        grasped_[i] = false;
      } else if (!jaws_were_closed_[i] && !grasped_[i]) {
        grasped_[i] = true;
        ++telemetry_[i].grasps;
      }
      // A shaft contact needs the shaft: without it the contact point is unknown.
      if (valid && (contact.shaft_offset == 0.0 || pose.shaft.squaredNorm() > 0.0)) {
        const Eigen::Vector3d displacement =
            pose.tip + contact.shaft_offset * pose.shaft - contact.action_point - slip_[i];
        force.noalias() = contact.force - contact.stiffness * (displacement - contact.reference);
        const bool pulls = force.dot(contact.normal) < 0.0;
        if (grasped_[i] && pulls && force.norm() > options_.grasp_limit) {
          // Pulled harder than the jaws hold: the tissue slips out of them.
          released_[i] = contact.generation;
          grasped_[i] = false;
          grasp_slipped = true;
          ++telemetry_[i].grasp_slips;
          telemetry_[i].peak_pull = std::max(telemetry_[i].peak_pull, force.norm());
          letting_go_[i] = telemetry_[i].last_force;
          force.setZero();
        } else if (!grasped_[i] && (displacement.dot(contact.normal) > contact.release_height + kReleaseMargin ||
                                    (contact.release_height > 0.0 && force.dot(contact.normal) < -kPullRelease))) {
          // Back outside: the contact ends now. One that began above the rest
          // surface (the organ moved onto a resting tool) also ends once the
          // organ would pull the tool: what pushed it there has let go.
          // Jaws that opened on a lifted patch let go of its pull.
          released_[i] = contact.generation;
          if (was_grasped) letting_go_[i] = telemetry_[i].last_force;
          force.setZero();
        } else {
          // Friction: outside Coulomb's cone the organ slips under the tool;
          // held in the jaws it does not.
          if (!grasped_[i]) slip_[i] -= slip_step(contact.stiffness, contact.normal, options_.friction, force);
          // A fresh linearization takes over from the last one over one
          // deformation period: the step between them (a dynamic model's
          // motion, points taken in or let go of) is felt as a ramp. At the
          // switch the hand feels what the last one gives at this tick's
          // displacement, so the tool's own move since the last tick is felt
          // at once, as on any other tick (a pose that arrives with a frame).
          if (blend_frame_[i] != contacts.time) {
            Eigen::Vector3d offset = Eigen::Vector3d::Zero();
            if (blend_generation_[i] == contact.generation) {
              const HeldLinearization& held = held_[i];
              Eigen::Vector3d last = held.force - held.stiffness * (displacement - held.reference);
              if (!grasped_[i]) slip_step(held.stiffness, contact.normal, options_.friction, last);
              offset = last + blend_left(i, now) * blend_offset_[i] - force;
            }
            blend_offset_[i] = offset;
            held_[i] = {contact.force, contact.stiffness, contact.reference};
            blend_frame_[i] = contacts.time;
            blend_start_[i] = now;
            blend_generation_[i] = contact.generation;
          }
          force += blend_left(i, now) * blend_offset_[i];
          // What the slope cannot take back (a force the model holds at any
          // displacement, a stiffness coupling the directions, the blend)
          // the cone clips; a grasp holds the organ both ways.
          if (!grasped_[i])
            clip_to_cone(contact.normal, options_.friction, force);
          else if (force.dot(contact.normal) < 0.0)
            telemetry_[i].peak_pull = std::max(telemetry_[i].peak_pull, force.norm());
          touching = true;
          depth = std::max(0.0, -displacement.dot(contact.normal));
        }
      }
    }
    if (touching) {
      letting_go_[i].setZero();
    } else if (letting_go_[i].squaredNorm() > 0.0) {
      // What a grasp held fades out at the onset rate, as a contact's force
      // comes in: letting go is not a kick either.
      const double left = letting_go_[i].norm() - devices_[i]->limits().onset_rate * dt;
      letting_go_[i] =
          left > 0.0 ? Eigen::Vector3d(letting_go_[i] * (left / letting_go_[i].norm())) : Eigen::Vector3d::Zero();
      force = letting_go_[i];
    }
    if (!valid) {
      // The device lost its pose (an error, a disconnection): fade what the
      // hand last felt rather than drop it at once, and resume through the
      // onset ramp when the pose comes back.
      if (fault_start_[i] < 0.0) {
        fault_start_[i] = now;
        fault_force_[i] = telemetry_[i].last_force;
        ++telemetry_[i].pose_faults;
      }
      const double ramp = devices_[i]->limits().ramp_down_time;
      const double remaining = ramp > 0.0 ? std::clamp(1.0 - (now - fault_start_[i]) / ramp, 0.0, 1.0) : 0.0;
      force = remaining * fault_force_[i];
    } else {
      fault_start_[i] = -1.0;
    }
    if (!contact.active || released_[i] == contact.generation) grasped_[i] = false;
    if (valid) jaws_were_closed_[i] = jaws;
    out.released[i] = released_[i];
    out.slips[i] = slip_[i];
    out.slip_generation[i] = seen_generation_[i];
    out.grasped[i] = grasped_[i];
    const Eigen::Vector3d safe = safety_[i].filter(force, now, last_frame, dt);
    devices_[i]->write_force(now, safe, touching);
    ToolTelemetry& t = telemetry_[i];
    t.in_contact = touching;
    t.last_force = safe;
    t.peak_force = std::max(t.peak_force, safe.norm());
    if (tick_records_[i].capacity() > 0)
      tick_records_[i].push({now, safe, force, out.tips[i], depth, touching, valid, jaws, grasped_[i], grasp_slipped});
  }
  tool_frames_.publish();
}

void Engine::deformation_step(double now) noexcept {
  tool_frames_.update();
  const ToolFrame& tools = tool_frames_.read();
  const auto& rest = organ_.model().surface_vertices;
  const auto& triangles = organ_.model().surface_triangles;
  // Every contact the force loop ended lets go first, so that a tool may take
  // what another held until now in the same frame.
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    ToolContact& contact = contacts_.tools[i];
    if (contact.active && tools.released[i] == contact.generation) {
      model_->detach(static_cast<std::uint32_t>(i));
      contact.active = false;
      // The patch the jaws let go of falls back from the tool: it does not
      // catch the tool again until the tool has moved.
      if (held_in_jaws_[i] && tools.tip_valid[i]) {
        refused_at_[i] = tools.tips[i];
        refused_valid_[i] = true;
      }
      held_in_jaws_[i] = false;
    }
  }
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    ToolContact& contact = contacts_.tools[i];
    const auto tool = static_cast<std::uint32_t>(i);
    const bool valid = tools.time >= 0.0 && tools.tip_valid[i];
    geometry::SegmentHit hit;
    double shaft_offset = 0.0;
    bool crossed = false;
    const bool retry = !refused_valid_[i] || (tools.tips[i] - refused_at_[i]).norm() > kRetryDistance;
    if (!contact.active && valid && retry) {
      // The contact tree follows the surface lazily: refitted (≈ 1 ms for 100k
      // vertices) only in frames where some tool looks for a contact, onto the
      // last published surface, which the writer does not touch until it has
      // published a newer one.
      if (tree_stale_) refit_contact_tree();
      crossed = previous_valid_[i] && deformed_tree_.first_crossing(previous_tip_[i], tools.tips[i], true, hit);
      const Eigen::Vector3d& shaft = tools.shafts[i];
      if (!crossed && shaft.squaredNorm() > 0.0) {
        const Eigen::Vector3d handle = tools.tips[i] + options_.shaft_length * shaft;
        crossed = deformed_tree_.first_crossing(handle, tools.tips[i], true, hit);
        if (crossed) shaft_offset = (1.0 - hit.along) * options_.shaft_length;
      }
      if (!crossed && previous_valid_[i] && tree_positions_ != nullptr) {
        const geometry::SurfacePoint nearest = deformed_tree_.closest_point(tools.tips[i]);
        const model::Triangle& t = triangles[nearest.triangle];
        const Eigen::Vector3d a = vec(tree_positions_[t[0]]), b = vec(tree_positions_[t[1]]),
                              c = vec(tree_positions_[t[2]]);
        if (nearest.distance < kCaughtDepth && (tools.tips[i] - nearest.position).dot((b - a).cross(c - a)) < 0.0) {
          crossed = true;
          hit.triangle = nearest.triangle;
          hit.barycentric = nearest.barycentric;
        }
      }
    }
    if (crossed) {
      const model::Triangle& t = triangles[hit.triangle];
      const Eigen::Vector3d rest_point = hit.barycentric[0] * vec(rest[t[0]]) + hit.barycentric[1] * vec(rest[t[1]]) +
                                         hit.barycentric[2] * vec(rest[t[2]]);
      geometry::SurfacePoint touched;
      touched.triangle = hit.triangle;
      touched.barycentric = hit.barycentric;
      const geometry::ToolTip tip = geometry::ToolTip::touching(options_.tip_radius_of(i), tools.shafts[i],
                                                                organ_.rest_normal_at(touched), options_.shaft_length);
      if (model_->attach(tool, rest_point, tip, linearizations_[i])) {
        contact.normal = linearizations_[i].normal;
        contact.action_point = linearizations_[i].action_point;
        publish_linearization(i);
        contact.shaft_offset = shaft_offset;
        // Caught by a surface that moved out onto the tool, the contact
        // begins above the rest surface's tangent plane: it ends only once
        // the tool has drawn back beyond where it began.
        const Eigen::Vector3d begun = tools.tips[i] + shaft_offset * tools.shafts[i] - contact.action_point;
        contact.release_height = std::max(0.0, begun.dot(contact.normal));
        contact.active = true;
        ++contact.generation;
        refused_valid_[i] = false;
      } else {
        ++refused_;
        refused_at_[i] = tools.tips[i];
        refused_valid_[i] = true;
      }
    }
    previous_tip_[i] = tools.tips[i];
    previous_valid_[i] = valid;
    // Without a valid pose (or, for a shaft contact, without the shaft) the
    // organ keeps its last shape rather than following a meaningless point.
    const bool located = valid && (contact.shaft_offset == 0.0 || tools.shafts[i].squaredNorm() > 0.0);
    if (!contact.active)
      displacement_[i].setZero();
    else if (located)
      displacement_[i] = tools.tips[i] + contact.shaft_offset * tools.shafts[i] - contact.action_point -
                         (tools.slip_generation[i] == contact.generation ? tools.slips[i] : Eigen::Vector3d::Zero());
  }
  const double dt = previous_step_ < 0.0 ? options_.deformation_period : now - previous_step_;
  previous_step_ = now;
  touched_ =
      std::any_of(contacts_.tools.begin(), contacts_.tools.begin() + static_cast<std::ptrdiff_t>(devices_.size()),
                  [](const ToolContact& c) { return c.active; });
  // The jaws hold a contact the force loop has seen; a contact begun in this
  // frame is not held yet.
  for (std::size_t i = 0; i < devices_.size(); ++i)
    if (contacts_.tools[i].active) {
      held_in_jaws_[i] = tools.grasped[i] && tools.slip_generation[i] == contacts_.tools[i].generation;
      model_->set_grasp(static_cast<std::uint32_t>(i), held_in_jaws_[i]);
    }
  SurfaceFrame& frame = surfaces_.write_slot();
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    frame.holding[i] = contacts_.tools[i].active && held_in_jaws_[i];
    frame.held_point[i] = contacts_.tools[i].action_point;
    frame.held_radius[i] = options_.tip_radius_of(i);
  }
  const bool moved =
      model_->step(dt, displacement_.data(), frame.positions.data(), frame.normals.data(), linearizations_.data());
  for (std::size_t i = 0; i < devices_.size(); ++i)
    if (contacts_.tools[i].active) publish_linearization(i);
  contacts_.time = now;
  contact_frames_.write_slot() = contacts_;
  contact_frames_.publish();
  if (!moved) return;  // cannot happen with finite tips; keep showing the previous frame
  note_moved_vertices();
  tree_positions_ = frame.positions.data();
  tree_stale_ = true;
  frame.frame = ++frame_;
  frame.time = now;
  surfaces_.publish();
}

void Engine::note_moved_vertices() noexcept {
  if (all_moved_) return;
  std::size_t count = 0;
  const std::uint32_t* moved = model_->moved_vertices(count);
  // Beyond a quarter of the surface the full refit costs about as much
  // (realtime_bench BM_ContactTreeRefit).
  if (moved == nullptr || moved_count_ + count > moved_list_.size() / 4) {
    all_moved_ = true;
    return;
  }
  for (std::size_t k = 0; k < count; ++k)
    if (moved[k] < moved_mark_.size() && !moved_mark_[moved[k]]) {
      moved_mark_[moved[k]] = 1;
      moved_list_[moved_count_++] = moved[k];
    }
}

void Engine::refit_contact_tree() noexcept {
  // Every surface is written whole, so a vertex that no step moved since the
  // last refit has the same coordinates in the newly published buffer.
  if (all_moved_) {
    deformed_tree_.refit(tree_positions_);
  } else {
    deformed_tree_.refit(tree_positions_, moved_list_.data(), moved_count_);
  }
  for (std::size_t k = 0; k < moved_count_; ++k) moved_mark_[moved_list_[k]] = 0;
  moved_count_ = 0;
  all_moved_ = false;
  tree_stale_ = false;
}

}  // namespace organsim::realtime
