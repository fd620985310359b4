// Forwarding header, kept for one release (docs/install.md): the runtime organ
// is now model-neutral, organsim::organ::Organ in organsim/organ/organ.h, and
// the multi-beam model builds its own beam data from it (MultiBeam refuses an
// organ without beam tables). BeamOrgan and the functions below are the same
// types and functions under their old names.
#pragma once

#include "organsim/organ/organ.h"

namespace organsim::multibeam {

using BeamOrgan [[deprecated("use organsim::organ::Organ (organsim/organ/organ.h)")]] = organ::Organ;
using organ::compute_vertex_normals;
using organ::morton_order;
using organ::renumber_in_morton_order;
using organ::vertex_kernel_level;

}  // namespace organsim::multibeam
