#include "model_validation.h"

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace organsim::model {

namespace {

template <std::size_t N>
std::string first_non_finite(const std::vector<std::array<double, N>>& values, const char* what) {
  for (std::size_t i = 0; i < values.size(); ++i)
    for (double c : values[i])
      if (!std::isfinite(c))
        return std::string(what) + " " + std::to_string(i) + " has a non-finite coordinate (NaN or Inf)";
  return {};
}

template <std::size_t N>
std::string first_bad_index(const std::vector<std::array<std::uint32_t, N>>& cells, std::size_t vertex_count,
                            const char* what, const char* vertices) {
  for (std::size_t i = 0; i < cells.size(); ++i)
    for (std::uint32_t v : cells[i])
      if (v >= vertex_count)
        return std::string(what) + " " + std::to_string(i) + " refers to vertex " + std::to_string(v) +
               " but there are only " + std::to_string(vertex_count) + " " + vertices;
  return {};
}

/// Fast path for millions of beam sections: true when every value is finite and
/// no area, second moment or torsion constant is negative. Branch-free so that
/// the compiler vectorizes it; the slow loop then finds the culprit.
bool is_lower_hex(const std::string& s) {
  for (char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

/// What is wrong with the meshing record, or "".
std::string meshing_issue(const OrganModel& m) {
  const Meshing& mesh = m.meshing;
  if (mesh == Meshing{}) return {};
  if (!(std::isfinite(mesh.tet_size) && mesh.tet_size > 0.0))
    return "the tetrahedron size must be a positive number of metres";
  if (!(std::isfinite(mesh.clamp_radius) && mesh.clamp_radius >= 0.0 && std::isfinite(mesh.clamp_cell_size) &&
        mesh.clamp_cell_size >= 0.0))
    return "the clamp radius and the clamp's cell size must be zero or positive numbers of metres";
  if (m.tetrahedra.empty()) return "a meshing record without tetrahedra";
  return {};
}

/// What is wrong with the supports, or "".
std::string supports_issue(const OrganModel& m) {
  const Supports& supports = m.supports;
  if (supports.empty()) return {};
  if (supports.vertices.size() != m.surface_vertices.size())
    return "there are " + std::to_string(supports.vertices.size()) + " support entries for " +
           std::to_string(m.surface_vertices.size()) + " surface vertices";
  for (std::size_t v = 0; v < supports.vertices.size(); ++v) {
    const auto& [kind, modulus] = supports.vertices[v];
    const bool free = kind == 0.0;
    if (!(kind == 0.0 || kind == 1.0 || kind == 2.0))
      return "the support kind of vertex " + std::to_string(v) + " is not 0 (free), 1 (contact) or 2 (attachment)";
    if (!(free ? modulus == 0.0 : modulus > 0.0 && modulus <= Supports::kMaxModulus))
      return "the foundation modulus of vertex " + std::to_string(v) +
             " must be 0 where it is free and a positive number of Pa/m up to 1e12 where it is supported";
  }
  return {};
}

/// What is wrong with the site curvature, or "".
std::string site_curvature_issue(const OrganModel& m) {
  const SiteCompliance& sites = m.sites;
  if (sites.curvature.empty()) return {};
  if (sites.empty()) return "curvatures without site compliances";
  if (sites.curvature.size() != m.surface_vertices.size())
    return "there are " + std::to_string(sites.curvature.size()) + " site curvatures for " +
           std::to_string(m.surface_vertices.size()) + " surface vertices";
  for (std::size_t v = 0; v < sites.curvature.size(); ++v) {
    const auto& [first, second] = sites.curvature[v];
    if (!(std::abs(first) <= SiteCompliance::kMaxCurvature && std::abs(second) <= SiteCompliance::kMaxCurvature &&
          first >= second))
      return "the curvatures of vertex " + std::to_string(v) + " are not finite numbers kappa1 >= kappa2 within +-" +
             std::to_string(static_cast<int>(SiteCompliance::kMaxCurvature)) + " 1/m";
  }
  return {};
}

/// Whether `c` is finite and passes a loose positive semi-definite test: no
/// negative diagonal entry, no 2×2 principal minor below zero (catches garbage).
bool plausible_compliance(const std::array<double, 6>& c) {
  bool finite = true;
  for (double x : c) finite &= std::isfinite(x);
  return finite && c[0] >= 0 && c[1] >= 0 && c[2] >= 0 && c[3] * c[3] <= c[0] * c[1] * (1 + 1e-9) + 1e-300 &&
         c[4] * c[4] <= c[0] * c[2] * (1 + 1e-9) + 1e-300 && c[5] * c[5] <= c[1] * c[2] * (1 + 1e-9) + 1e-300;
}

/// What is wrong with the site compliance on the supports, or "".
std::string supported_sites_issue(const OrganModel& m) {
  const SiteCompliance& sites = m.sites;
  if (sites.supported.empty()) return {};
  if (sites.empty()) return "site compliances on the supports without site compliances";
  if (m.supports.empty()) return "site compliances on the supports without supports";
  if (sites.supported.size() != m.surface_vertices.size())
    return "there are " + std::to_string(sites.supported.size()) + " site compliances on the supports for " +
           std::to_string(m.surface_vertices.size()) + " surface vertices";
  for (std::size_t v = 0; v < sites.supported.size(); ++v)
    if (!plausible_compliance(sites.supported[v]))
      return "the compliance on the supports of vertex " + std::to_string(v) +
             " is not finite or not positive semi-definite";
  return {};
}

/// What is wrong with a depth curve (`name`) and the tip radius it was fitted
/// for, or "".
std::string depth_curve_issue(const std::string& name, const std::vector<std::array<double, 2>>& curve,
                              double tip_radius) {
  if (!(std::isfinite(tip_radius) && tip_radius >= 0)) return "the " + name + "'s tip radius must be a length >= 0";
  if (!curve.empty() && !(tip_radius > 0)) return "a " + name + " needs the tip radius it was fitted with";
  double last = -1.0;
  for (const auto& [depth, factor] : curve) {
    if (!(std::isfinite(depth) && depth > last && depth >= 0))
      return "the " + name + "'s depths must be finite, >= 0 and increasing";
    if (!(std::isfinite(factor) && factor > 0)) return "the " + name + "'s factors must be positive numbers";
    last = depth;
  }
  return {};
}

/// What is wrong with the site compliance, or "".
std::string site_compliance_issue(const OrganModel& m) {
  const SiteCompliance& sites = m.sites;
  if (sites.empty()) {
    if (!sites.depth_curve.empty()) return "a depth curve without site compliances";
    return {};
  }
  if (sites.compliance.size() != m.surface_vertices.size())
    return "there are " + std::to_string(sites.compliance.size()) + " site compliances for " +
           std::to_string(m.surface_vertices.size()) + " surface vertices";
  if (!(std::isfinite(sites.young_modulus) && sites.young_modulus > 0))
    return "the reference's Young's modulus must be a positive number of pascals";
  if (!(std::isfinite(sites.poisson_ratio) && sites.poisson_ratio > 0 && sites.poisson_ratio < 0.5))
    return "the reference's Poisson's ratio must lie in (0, 0.5)";
  for (std::size_t v = 0; v < sites.compliance.size(); ++v) {
    if (!plausible_compliance(sites.compliance[v]))
      return "the compliance of vertex " + std::to_string(v) + " is not finite or not positive semi-definite";
  }
  return depth_curve_issue("depth curve", sites.depth_curve, sites.curve_tip_radius);
}

/// What is wrong with the depth curve on the supports, or "".
std::string supported_depth_curve_issue(const OrganModel& m) {
  const SiteCompliance& sites = m.sites;
  if (!sites.supported_depth_curve.empty() && sites.supported.empty())
    return "a depth curve on the supports without site compliances on them";
  return depth_curve_issue("depth curve on the supports", sites.supported_depth_curve,
                           sites.supported_curve_tip_radius);
}

/// What is wrong with the pull curve, or "".
std::string pull_curve_issue(const OrganModel& m) {
  const SiteCompliance& sites = m.sites;
  if (!sites.pull_curve.empty() && sites.empty()) return "a pull curve without site compliances";
  if (!(std::isfinite(sites.pull_tip_radius) && sites.pull_tip_radius >= 0))
    return "the pull curve's tip radius must be a length >= 0";
  if (!sites.pull_curve.empty() && !(sites.pull_tip_radius > 0))
    return "a pull curve needs the tip radius it was fitted with";
  double last = -1.0;
  for (const auto& [distance, softening] : sites.pull_curve) {
    if (!(std::isfinite(distance) && distance > last && distance >= 0))
      return "the pull curve's distances must be finite, >= 0 and increasing";
    if (!(std::isfinite(softening) && softening > 0 && softening <= SiteCompliance::kMaxSoftening))
      return "the pull curve's softenings must be positive numbers up to " +
             std::to_string(static_cast<int>(SiteCompliance::kMaxSoftening));
    last = distance;
  }
  return {};
}

}  // namespace

// One pass with no chain of dependent additions (a running sum of x - x, the
// obvious finiteness test, runs at the adder's latency): exponent bits all
// ones means NaN or infinite.
bool beam_values_plausible(const BeamSection* sections, std::size_t count) noexcept {
  constexpr std::uint64_t kExponent = 0x7ff0000000000000u;
  bool non_finite = false, negative = false;
  for (std::size_t i = 0; i < count; ++i) {
    const BeamSection& s = sections[i];
    const double v[] = {s.area, s.i_yy, s.i_zz, s.i_yz, s.torsion_j, s.centroid_y, s.centroid_z};
    for (double x : v) {
      std::uint64_t bits;
      std::memcpy(&bits, &x, sizeof bits);
      non_finite |= (bits & kExponent) == kExponent;
    }
    negative |= (s.area < 0) | (s.i_yy < 0) | (s.i_zz < 0) | (s.torsion_j < 0);
  }
  return !non_finite && !negative;
}

std::optional<ModelIssue> find_model_issue(const OrganModel& m, bool beam_values_plausible_already) {
  auto issue = [](format::Section s, std::string message) {
    return std::optional<ModelIssue>(ModelIssue{s, std::move(message)});
  };
  const auto& p = m.provenance;
  if (p.coordinate_frame != "LPS" && p.coordinate_frame != "RAS")
    return issue(format::Section::Metadata, "coordinate frame '" + p.coordinate_frame + "' is neither LPS nor RAS");
  if (!p.input_sha256.empty() && (p.input_sha256.size() != 64 || !is_lower_hex(p.input_sha256)))
    return issue(format::Section::Metadata, "input SHA-256 is not 64 lowercase hexadecimal digits");

  if (m.surface_vertices.size() < 4)
    return issue(format::Section::SurfaceVertices, "the surface has fewer than 4 vertices");
  if (m.surface_triangles.size() < 4)
    return issue(format::Section::SurfaceTriangles, "the surface has fewer than 4 triangles");
  if (m.surface_vertices.size() > UINT32_MAX)
    return issue(format::Section::SurfaceVertices, "the surface has more than 2^32-1 vertices");
  if (auto e = first_non_finite(m.surface_vertices, "surface vertex"); !e.empty())
    return issue(format::Section::SurfaceVertices, e);
  if (auto e = first_bad_index(m.surface_triangles, m.surface_vertices.size(), "surface triangle", "surface vertices");
      !e.empty())
    return issue(format::Section::SurfaceTriangles, e);
  for (std::size_t i = 0; i < m.surface_triangles.size(); ++i) {
    const Triangle& t = m.surface_triangles[i];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      return issue(format::Section::SurfaceTriangles, "surface triangle " + std::to_string(i) + " repeats a vertex");
  }
  if (!m.surface_texcoords.empty()) {
    if (m.surface_texcoords.size() != m.surface_vertices.size())
      return issue(format::Section::SurfaceTexcoords,
                   "there are " + std::to_string(m.surface_texcoords.size()) + " texture coordinates for " +
                       std::to_string(m.surface_vertices.size()) + " surface vertices");
    if (auto e = first_non_finite(m.surface_texcoords, "texture coordinate"); !e.empty())
      return issue(format::Section::SurfaceTexcoords, e);
  }

  if (!m.tetrahedra.empty() && m.volume_vertices.empty())
    return issue(format::Section::Tetrahedra, "there are tetrahedra but no tetrahedron vertices");
  if (m.volume_vertices.size() > UINT32_MAX)
    return issue(format::Section::VolumeVertices, "the volume mesh has more than 2^32-1 vertices");
  if (auto e = first_non_finite(m.volume_vertices, "tetrahedron vertex"); !e.empty())
    return issue(format::Section::VolumeVertices, e);
  if (auto e = first_bad_index(m.tetrahedra, m.volume_vertices.size(), "tetrahedron", "tetrahedron vertices");
      !e.empty())
    return issue(format::Section::Tetrahedra, e);

  if (m.fixed_points.empty()) return issue(format::Section::FixedPoints, "there is no fixed point");
  if (auto e = first_non_finite(m.fixed_points, "fixed point"); !e.empty())
    return issue(format::Section::FixedPoints, e);

  const Material& mat = m.material;
  if (!(std::isfinite(mat.young_modulus) && mat.young_modulus > 0))
    return issue(format::Section::Material, "Young's modulus must be a positive number of pascals");
  if (!(std::isfinite(mat.poisson_ratio) && mat.poisson_ratio > -1.0 && mat.poisson_ratio < 0.5))
    return issue(format::Section::Material, "Poisson's ratio must lie in (-1, 0.5)");
  if (!(std::isfinite(mat.density) && mat.density > 0))
    return issue(format::Section::Material, "density must be a positive number of kg/m^3");
  if (!(std::isfinite(mat.attenuation_alpha) && mat.attenuation_alpha > 0))
    return issue(format::Section::Material, "attenuation alpha must be positive");
  if (!(std::isfinite(mat.attenuation_beta) && mat.attenuation_beta >= 0))
    return issue(format::Section::Material, "attenuation beta must be zero or positive (1/m)");
  if (!(std::isfinite(mat.beam_stiffness_scale) && mat.beam_stiffness_scale > 0 &&
        std::isfinite(mat.spring_stiffness_scale) && mat.spring_stiffness_scale > 0))
    return issue(format::Section::Material, "the beam and spring stiffness scales must be positive");

  if (auto e = site_compliance_issue(m); !e.empty()) return issue(format::Section::SiteCompliance, e);
  if (auto e = pull_curve_issue(m); !e.empty()) return issue(format::Section::PullCurve, e);
  if (auto e = site_curvature_issue(m); !e.empty()) return issue(format::Section::SiteCurvature, e);
  if (auto e = meshing_issue(m); !e.empty()) return issue(format::Section::Meshing, e);
  if (auto e = supports_issue(m); !e.empty()) return issue(format::Section::Supports, e);
  if (auto e = supported_sites_issue(m); !e.empty()) return issue(format::Section::SupportedSiteCompliance, e);
  if (auto e = supported_depth_curve_issue(m); !e.empty()) return issue(format::Section::SupportedDepthCurve, e);

  const BeamTables& b = m.beams;
  if (b.empty()) {
    if (!b.sections.empty())
      return issue(format::Section::BeamTables, "beam sections are present but stations per beam is zero");
  } else {
    if (b.sections.size() / b.stations_per_beam != m.surface_vertices.size() ||
        b.sections.size() % b.stations_per_beam != 0)
      return issue(format::Section::BeamTables, "beam tables hold " + std::to_string(b.sections.size()) +
                                                    " sections, expected " + std::to_string(m.surface_vertices.size()) +
                                                    " vertices x " + std::to_string(b.stations_per_beam) + " stations");
    if (beam_values_plausible_already || beam_values_plausible(b.sections.data(), b.sections.size()))
      return std::nullopt;
    for (std::size_t i = 0; i < b.sections.size(); ++i) {
      const BeamSection& s = b.sections[i];
      const double v[] = {s.area, s.i_yy, s.i_zz, s.i_yz, s.torsion_j, s.centroid_y, s.centroid_z};
      // The message is built only on failure: this loop runs over millions of sections.
      auto where = [&] {
        return "beam section of vertex " + std::to_string(i / b.stations_per_beam) + ", station " +
               std::to_string(i % b.stations_per_beam);
      };
      for (double x : v)
        if (!std::isfinite(x))
          return issue(format::Section::BeamTables, where() + " has a non-finite value (NaN or Inf)");
      if (s.area < 0 || s.i_yy < 0 || s.i_zz < 0 || s.torsion_j < 0)
        return issue(format::Section::BeamTables, where() + " has a negative area, second moment or torsion constant");
    }
  }
  return std::nullopt;
}

}  // namespace organsim::model
