#include "organsim/model/organ_model.h"

#include <algorithm>

#include <cmath>

#include "model_validation.h"

#include <string>

namespace organsim::model {

Material liver_default_material() {
  Material m;
  m.young_modulus = 5000.0;
  m.poisson_ratio = 0.45;
  m.density = 1060.0;
  m.attenuation_alpha = std::exp(1.0);
  m.attenuation_beta = 20.0;
  return m;
}

bool Material::operator==(const Material& o) const {
  return young_modulus == o.young_modulus && poisson_ratio == o.poisson_ratio && density == o.density &&
         attenuation_alpha == o.attenuation_alpha && attenuation_beta == o.attenuation_beta &&
         beam_stiffness_scale == o.beam_stiffness_scale && spring_stiffness_scale == o.spring_stiffness_scale;
}

bool BeamSection::operator==(const BeamSection& o) const {
  return area == o.area && i_yy == o.i_yy && i_zz == o.i_zz && i_yz == o.i_yz && torsion_j == o.torsion_j &&
         centroid_y == o.centroid_y && centroid_z == o.centroid_z;
}

SectionTable SectionTable::view(const BeamSection* data, std::size_t count, std::shared_ptr<const void> keep_alive) {
  SectionTable table;
  table.data_ = data;
  table.size_ = count;
  table.mapping_ = std::move(keep_alive);
  return table;
}

SectionTable::SectionTable(const SectionTable& other) : owned_(other.owned_), mapping_(other.mapping_) {
  if (mapping_) {
    data_ = other.data_;
    size_ = other.size_;
  } else {
    sync();
  }
}

SectionTable& SectionTable::operator=(const SectionTable& other) {
  if (this != &other) *this = SectionTable(other);
  return *this;
}

SectionTable::SectionTable(SectionTable&& other) noexcept
    : owned_(std::move(other.owned_)), data_(other.data_), size_(other.size_), mapping_(std::move(other.mapping_)) {
  other.sync();
}

SectionTable& SectionTable::operator=(SectionTable&& other) noexcept {
  owned_ = std::move(other.owned_);
  data_ = other.data_;
  size_ = other.size_;
  mapping_ = std::move(other.mapping_);
  other.sync();
  return *this;
}

std::vector<BeamSection>& SectionTable::owned() {
  if (mapping_) {
    owned_.assign(data_, data_ + size_);
    mapping_.reset();
    sync();
  }
  return owned_;
}

bool SectionTable::operator==(const SectionTable& o) const {
  return size_ == o.size_ && std::equal(begin(), end(), o.begin());
}

bool BeamTables::operator==(const BeamTables& o) const {
  return stations_per_beam == o.stations_per_beam && sections == o.sections;
}

bool SiteCompliance::operator==(const SiteCompliance& o) const {
  return young_modulus == o.young_modulus && poisson_ratio == o.poisson_ratio && compliance == o.compliance &&
         depth_curve == o.depth_curve && curve_tip_radius == o.curve_tip_radius && curvature == o.curvature &&
         pull_curve == o.pull_curve && pull_tip_radius == o.pull_tip_radius && supported == o.supported &&
         supported_depth_curve == o.supported_depth_curve && supported_curve_tip_radius == o.supported_curve_tip_radius;
}

bool Meshing::operator==(const Meshing& o) const {
  return tet_size == o.tet_size && clamp_radius == o.clamp_radius && clamp_cell_size == o.clamp_cell_size;
}

bool ModelProvenance::operator==(const ModelProvenance& o) const {
  return coordinate_frame == o.coordinate_frame && program_version == o.program_version &&
         input_sha256 == o.input_sha256 && parameters == o.parameters;
}

bool OrganModel::operator==(const OrganModel& o) const {
  return provenance == o.provenance && surface_vertices == o.surface_vertices &&
         surface_triangles == o.surface_triangles && surface_texcoords == o.surface_texcoords &&
         volume_vertices == o.volume_vertices && tetrahedra == o.tetrahedra && fixed_points == o.fixed_points &&
         material == o.material && beams == o.beams && sites == o.sites && meshing == o.meshing &&
         supports == o.supports;
}

std::string validate_organ_model(const OrganModel& model) {
  const std::optional<ModelIssue> issue = find_model_issue(model);
  return issue ? issue->message : std::string();
}

}  // namespace organsim::model
