// `organsim export MODEL [--surface OUT.vtp|.stl|.obj] [--tetrahedra OUT.vtu]
// [--beam V OUT.csv]`: a model's contents back out as files that 3D Slicer,
// ParaView and Blender open, in the model file's vertex order.
#include <cctype>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "command_line/command_line.h"
#include "organsim/io/atomic_file.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"

namespace organsim::cli {
namespace {

struct ExportOptions {
  std::string model_path, surface_path, tetrahedra_path;
  std::vector<std::string> beam;  ///< V OUT.csv
};

std::string lower_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

/// One row per station: where it sits along the beam and its cross-section (SI).
/// The supports per surface vertex (docs/supports.md), for ParaView and 3D
/// Slicer to colour: empty when the model has none.
std::vector<mesh_io::DataArray> support_arrays(const model::OrganModel& m) {
  if (m.supports.empty()) return {};
  mesh_io::DataArray kind{"support_kind", 1, {}}, modulus{"foundation_modulus_pa_per_m", 1, {}};
  for (const auto& [k, stiffness] : m.supports.vertices) kind.values.push_back(k), modulus.values.push_back(stiffness);
  return {kind, modulus};
}

std::string beam_table_csv(const model::OrganModel& m, std::uint32_t vertex) {
  std::ostringstream csv;
  csv.precision(17);
  csv << "station,t,area_m2,i_yy_m4,i_zz_m4,i_yz_m4,torsion_j_m4,centroid_y_m,centroid_z_m\n";
  for (std::uint32_t s = 0; s < m.beams.stations_per_beam; ++s) {
    const model::BeamSection& section = m.beams.at(vertex, s);
    csv << s << ',' << (s + 0.5) / m.beams.stations_per_beam << ',' << section.area << ',' << section.i_yy << ','
        << section.i_zz << ',' << section.i_yz << ',' << section.torsion_j << ',' << section.centroid_y << ','
        << section.centroid_z << '\n';
  }
  return csv.str();
}

int run_export(const ExportOptions& o) {
  if (o.surface_path.empty() && o.tetrahedra_path.empty() && o.beam.empty())
    throw CLI::ValidationError("export", "nothing to export: give --surface, --tetrahedra or --beam");
  const model::ModelReadResult read = model::read_organ_model_file(o.model_path);
  if (!read) throw std::runtime_error(read.error);
  const model::OrganModel& m = *read.model;

  // Every check before the first file is written: a bad option writes nothing.
  const std::string surface_kind = lower_extension(o.surface_path);
  if (!o.surface_path.empty() && surface_kind != ".vtp" && surface_kind != ".stl" && surface_kind != ".obj")
    throw std::runtime_error(fmt::format("--surface {}: the file name must end in .vtp, .stl or .obj", o.surface_path));
  if (!o.tetrahedra_path.empty()) {
    if (lower_extension(o.tetrahedra_path) != ".vtu")
      throw std::runtime_error(fmt::format("--tetrahedra {}: the file name must end in .vtu", o.tetrahedra_path));
    if (m.tetrahedra.empty())
      throw std::runtime_error(o.model_path + ": the model has no tetrahedra (baked with --no-tetrahedra?)");
  }
  std::uint32_t beam_vertex = 0;
  if (!o.beam.empty()) {
    std::size_t parsed = 0;
    long long vertex = -1;
    try {
      vertex = std::stoll(o.beam[0], &parsed);
    } catch (const std::exception&) {
      parsed = 0;
    }
    if (parsed != o.beam[0].size() || vertex < 0)
      throw std::runtime_error(
          fmt::format("--beam {} {}: the vertex must be a surface vertex number", o.beam[0], o.beam[1]));
    if (m.beams.empty())
      throw std::runtime_error(o.model_path + ": the model has no beam tables; re-bake it with --stations N");
    if (static_cast<std::size_t>(vertex) >= m.surface_vertices.size())
      throw std::runtime_error(fmt::format("--beam {} is out of range: the model has {} surface vertices (0..{})",
                                           vertex, m.surface_vertices.size(), m.surface_vertices.size() - 1));
    beam_vertex = static_cast<std::uint32_t>(vertex);
  }

  if (!o.surface_path.empty()) {
    const geometry::SurfaceMesh surface{m.surface_vertices, m.surface_triangles};
    if (surface_kind == ".vtp")
      mesh_io::write_surface_vtp(surface, o.surface_path, support_arrays(m));
    else if (surface_kind == ".stl")
      mesh_io::write_surface_stl(surface, o.surface_path);
    else
      mesh_io::write_surface_obj(surface, o.surface_path);
    std::cout << fmt::format("{:<14}{} ({} vertices, {} triangles, mm, LPS{})\n", "surface", o.surface_path,
                             m.surface_vertices.size(), m.surface_triangles.size(),
                             surface_kind == ".vtp" && !m.supports.empty()
                                 ? "; point data support_kind (0 free, 1 contact, 2 attachment), "
                                   "foundation_modulus_pa_per_m"
                                 : "");
  }
  if (!o.tetrahedra_path.empty()) {
    mesh_io::write_tetrahedra_vtu({m.volume_vertices, m.tetrahedra}, o.tetrahedra_path);
    std::cout << fmt::format("{:<14}{} ({} nodes, {} tetrahedra, mm, LPS)\n", "tetrahedra", o.tetrahedra_path,
                             m.volume_vertices.size(), m.tetrahedra.size());
  }
  if (!o.beam.empty()) {
    io::write_file_atomically(o.beam[1], beam_table_csv(m, beam_vertex));
    std::cout << fmt::format("{:<14}{} (vertex {}: {} stations, SI units)\n", "beam", o.beam[1], beam_vertex,
                             m.beams.stations_per_beam);
  }
  return 0;
}

}  // namespace

Command add_export_command(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("--surface", o->surface_path,
                 "Write the surface: .vtp (ParaView, 3D Slicer), .stl or .obj (Blender); mm, LPS");
  app.add_option("--tetrahedra", o->tetrahedra_path, "Write the tetrahedral mesh as .vtu; mm, LPS");
  app.add_option("--beam", o->beam, "Write the beam table of surface vertex V as CSV (one row per station, SI)")
      ->expected(2)
      ->type_name("V OUT.csv");
  return [o] { return run_export(*o); };
}

}  // namespace organsim::cli
