// What the organ rests on and is attached to in the body, found in the
// patient's CT (docs/supports.md): each surface vertex looks outwards along
// its normal, and where the CT a few millimetres outside is tissue (soft
// tissue, fluid or bone) rather than air, lung or fat, the organ lies against
// a neighbour there. Supported vertices about the surface point nearest the
// fixed point are the organ's attachments (the liver's bare area and its
// ligaments about the hilum); the others are contacts, which push back only
// when pressed.
//
// Units: the options in millimetres and HU as the command line gives them;
// the model and the supports in SI (m, Pa/m).
#pragma once

#include <cstddef>

#include "organsim/model/organ_model.h"
#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

struct SupportOptions {
  /// The band outside the surface the CT is read in, mm along the outward
  /// normal: far enough out to leave the organ's own border voxels behind,
  /// near enough that what is read touches the organ.
  double near_mm = 2.0, far_mm = 5.0;
  int samples = 4;               ///< points read across the band (≥ 2)
  double tissue_low_hu = -30.0;  ///< below: fat, lung, air (no support); from here up: tissue, fluid, bone
  /// Supported vertices within this distance of the surface point nearest
  /// the fixed point are attachments (the bare area and the ligaments about
  /// the vena cava and the portal vein), mm; 0: none.
  double attachment_radius_mm = 30.0;
  /// The foundation modulus k = E / depth (Pa/m): a neighbour of Young's
  /// modulus E (Pa; 0: the organ's own) yielding over `yielding_depth_mm`.
  double tissue_young_modulus = 0.0;
  double yielding_depth_mm = 20.0;
};

struct SupportReport {
  std::size_t contact_vertices = 0, attachment_vertices = 0, free_vertices = 0;
  std::size_t unseen_vertices = 0;  ///< free because the band lies outside the CT (its field of view)
  double contact_area_cm2 = 0.0, attachment_area_cm2 = 0.0, surface_area_cm2 = 0.0;
  double modulus = 0.0;  ///< Pa/m, as stored for every supported vertex
};

/// The supports of `model` (its surface, fixed point and material) in `ct`,
/// whose physical frame (LPS mm) is the model's (m × 1000). Deterministic.
/// Throws std::runtime_error for options out of range.
model::Supports find_supports(const CtImage& ct, const model::OrganModel& model, const SupportOptions& options,
                              SupportReport* report = nullptr);

}  // namespace organsim::pipeline
