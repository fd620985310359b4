// organsim._organsim: the Python module's compiled part (pybind11). The
// package organsim (organsim/__init__.py) is what users import; it adds
// organsim.bake's keyword arguments on top of this.
//
// Arrays: a model's arrays are numpy views of the loaded model's memory (no
// copy; they keep the Model alive, and are read-only: a model is what its file
// says). Units are SI throughout (m, N, Pa, s), as in the model file.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bake_command.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/devices/session_file.h"
#include "organsim/geometry/model_measures.h"
#include "organsim/geometry/tool_tip.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/loop_runner.h"
#include "organsim/realtime/session_playback.h"
#include "organsim/version.h"

namespace py = pybind11;

namespace organsim::python {
namespace {

using model::OrganModel;
using Model = std::shared_ptr<OrganModel>;  // never changed after load(): its arrays are read-only views

/// `array`, made read-only: a model is what its file says.
py::array read_only(py::array array) {
  py::detail::array_proxy(array.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return array;
}

/// A read-only numpy view of `rows` × `columns` values at `data`, kept alive by `owner`.
template <typename T>
py::array view(const T* data, std::size_t rows, std::size_t columns, const py::object& owner) {
  return read_only(py::array(py::dtype::of<T>(), {rows, columns}, {columns * sizeof(T), sizeof(T)}, data, owner));
}

Model load(const std::string& path) {
  model::ModelReadResult read = model::read_organ_model_file(path);
  if (!read) throw std::runtime_error(read.error);
  return std::make_shared<OrganModel>(std::move(*read.model));
}

multibeam::MergeRule merge_rule(const std::string& merge) {
  multibeam::MergeRule rule{};
  if (!multibeam::parse_merge_rule(merge, rule))
    throw std::invalid_argument("merge must be 'influence' or 'sum', not '" + merge + "'");
  return rule;
}

multibeam::BeamTheory beam_theory(const std::string& theory) {
  multibeam::BeamTheory parsed{};
  if (!multibeam::parse_beam_theory(theory, parsed))
    throw std::invalid_argument("theory must be 'euler-bernoulli' or 'timoshenko', not '" + theory + "'");
  return parsed;
}

/// Vertex positions in the organ's (Morton) order → an (N, 3) array in the
/// model file's order.
py::array_t<double> in_file_order(const organ::Organ& organ, const std::vector<model::Point3>& points) {
  py::array_t<double> out({points.size(), std::size_t{3}});
  auto o = out.mutable_unchecked<2>();
  const std::vector<std::uint32_t>& file_index = organ.file_vertex_index();
  for (std::size_t v = 0; v < points.size(); ++v)
    for (py::ssize_t k = 0; k < 3; ++k) o(file_index[v], k) = points[v][k];
  return out;
}

std::vector<Eigen::Vector3d> displacements_of(const py::array_t<double, py::array::c_style | py::array::forcecast>& d,
                                              std::size_t tools) {
  if (d.ndim() != 2 || d.shape(1) != 3 || static_cast<std::size_t>(d.shape(0)) != tools)
    throw std::invalid_argument("tip displacements must be an array of shape (" + std::to_string(tools) +
                                ", 3): one row per tool, m");
  std::vector<Eigen::Vector3d> out(tools);
  auto r = d.unchecked<2>();
  for (std::size_t t = 0; t < tools; ++t) out[t] = {r(t, 0), r(t, 1), r(t, 2)};
  return out;
}

void check_status(multibeam::Status status) {
  if (status != multibeam::Status::ok) throw std::runtime_error(multibeam::describe(status));
}

/// The multi-beam model (Ushiki et al.) on a model: attach tools, read their
/// forces, deform the surface.
class MultiBeamModel {
 public:
  MultiBeamModel(const Model& model, std::uint32_t max_tools, const std::string& merge, const std::string& theory)
      : organ_(std::make_shared<organ::Organ>(*model)), beam_(*organ_, options(max_tools, merge, theory)) {}

  void attach(std::uint32_t tool, const Eigen::Vector3d& point) {
    check_tool(tool);
    check_status(beam_.attach(tool, point));
  }
  void detach(std::uint32_t tool) {
    check_tool(tool);
    beam_.detach(tool);
  }
  Eigen::Vector3d force(std::uint32_t tool, const Eigen::Vector3d& tip_displacement) const {
    check_tool(tool);
    Eigen::Vector3d f;
    check_status(beam_.force(tool, tip_displacement, f));
    return f;
  }
  Eigen::Vector3d action_point(std::uint32_t tool) const {
    check_tool(tool);
    if (!beam_.beam(tool).attached) throw std::runtime_error(multibeam::describe(multibeam::Status::no_contact));
    return beam_.beam(tool).action.position;
  }
  Eigen::Matrix3d stiffness(std::uint32_t tool) const {
    check_tool(tool);
    if (!beam_.beam(tool).attached) throw std::runtime_error(multibeam::describe(multibeam::Status::no_contact));
    return beam_.beam(tool).stiffness;
  }
  py::tuple deform(const py::array_t<double, py::array::c_style | py::array::forcecast>& tip_displacements) {
    const std::vector<Eigen::Vector3d> d = displacements_of(tip_displacements, beam_.max_tools());
    std::vector<model::Point3> positions(organ_->vertex_count()), normals(organ_->vertex_count());
    {
      py::gil_scoped_release released;
      check_status(beam_.deform(d.data(), positions.data(), normals.data(), positions.size()));
    }
    return py::make_tuple(in_file_order(*organ_, positions), in_file_order(*organ_, normals));
  }
  std::uint32_t max_tools() const { return beam_.max_tools(); }

 private:
  static multibeam::MultiBeamOptions options(std::uint32_t max_tools, const std::string& merge,
                                             const std::string& theory) {
    multibeam::MultiBeamOptions o;
    if (max_tools < 1 || max_tools > multibeam::kMaxTools)
      throw std::invalid_argument("max_tools must be 1 to " + std::to_string(multibeam::kMaxTools));
    o.max_tools = max_tools;
    o.merge = merge_rule(merge);
    o.beam.theory = beam_theory(theory);
    return o;
  }
  void check_tool(std::uint32_t tool) const {
    if (tool >= beam_.max_tools())
      throw std::out_of_range("tool " + std::to_string(tool) + " is out of range: this model takes tools 0.." +
                              std::to_string(beam_.max_tools() - 1));
  }
  std::shared_ptr<organ::Organ> organ_;
  multibeam::MultiBeam beam_;
};

/// A registered model's name (ValueError otherwise) that can run on `model`
/// (organsim.Error with the one line that says how to bake one otherwise).
void check_model_name(const std::string& name, const model::OrganModel& model) {
  const realtime::RegisteredModel* entry = realtime::find_model(name);
  if (!entry) throw std::invalid_argument("unknown model '" + name + "': " + realtime::model_names(", "));
  if (const std::string why = realtime::unsuitable_model(*entry, model); !why.empty()) throw std::runtime_error(why);
}

/// The models' options from keyword arguments: each a registered parameter
/// (model_options.h) with '_' for '-', a length in m, a flag True or False, a
/// choice's name, a number. ValueError for a name no model takes or a value out of range.
realtime::ModelOptions model_options(const py::kwargs& settings) {
  realtime::ModelOptions options;
  for (const auto& [key, value] : settings) {
    std::string name = py::cast<std::string>(key);
    std::replace(name.begin(), name.end(), '_', '-');
    std::string known;
    bool taken = false;
    for (const realtime::RegisteredModel* entry : realtime::registered_models())
      for (std::size_t k = 0; k < entry->parameter_count; ++k) {
        const realtime::ModelParameter& parameter = entry->parameters[k];
        if (known.find(std::string(" ") + parameter.name + ",") == std::string::npos)
          known += std::string(" ") + parameter.name + ",";
        if (name != parameter.name) continue;
        taken = true;
        std::string text;
        realtime::ParameterValue given;
        if (parameter.kind == realtime::ModelParameter::Kind::choice) {
          text = py::cast<std::string>(value);
          given.text = text;
        } else {
          given.number = parameter.kind == realtime::ModelParameter::Kind::flag ? (py::cast<bool>(value) ? 1.0 : 0.0)
                                                                                : py::cast<double>(value);
        }
        if (const std::string why = parameter.set(options, given); !why.empty())
          throw std::invalid_argument(py::cast<std::string>(key) + ": " + why);
      }
    if (!taken) {
      std::replace(known.begin(), known.end(), '-', '_');
      throw std::invalid_argument("no model takes the setting '" + py::cast<std::string>(key) +
                                  "'; the models' settings are" + known.substr(0, known.size() - 1));
    }
  }
  return options;
}

/// The keyword arguments model_options() takes, for the help texts.
std::string settings_help() {
  std::string help = "Settings (keyword arguments; lengths in m):";
  std::vector<std::string> listed;
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    for (std::size_t k = 0; k < entry->parameter_count; ++k) {
      const realtime::ModelParameter& parameter = entry->parameters[k];
      if (std::find(listed.begin(), listed.end(), parameter.name) != listed.end()) continue;
      listed.emplace_back(parameter.name);
      std::string name = parameter.name;
      std::replace(name.begin(), name.end(), '-', '_');
      help += "\n  " + name + ": " + parameter.help;
    }
  return help;
}

/// Any of the engine's deformation models (model_registry.h) through the
/// engine's own interface: attach a tool, step time with the tools'
/// displacements, read each contact's force.
class Simulation {
 public:
  Simulation(const Model& model, const std::string& kind, std::uint32_t tools, double tip_radius,
             const py::kwargs& settings)
      : organ_(std::make_shared<organ::Organ>(*model)),
        tip_radius_(tip_radius),
        contacts_(tools),
        attached_(tools, false) {
    check_model_name(kind, *model);
    if (!geometry::ToolTip::valid_radius(tip_radius)) throw std::invalid_argument("tip_radius must be >= 0, m");
    if (tools < 1 || tools > multibeam::kMaxTools)
      throw std::invalid_argument("tools must be 1 to " + std::to_string(multibeam::kMaxTools));
    model_ = realtime::make_deformation_model(kind, *organ_, model_options(settings), tools);
    positions_.resize(organ_->vertex_count());
    normals_.resize(organ_->vertex_count());
  }

  py::dict attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const std::optional<Eigen::Vector3d>& shaft) {
    check_tool(tool);
    if (shaft && (!(shaft->norm() > 0.0) || !shaft->allFinite()))
      throw std::invalid_argument("the shaft direction is zero or not finite");
    const Eigen::Vector3d normal = organ_->rest_normal_at(organ_->surface_tree().closest_point(rest_point));
    const geometry::ToolTip tip =
        geometry::ToolTip::touching(tip_radius_, shaft.value_or(Eigen::Vector3d::Zero()), normal);
    if (!model_->attach(tool, rest_point, tip, contacts_[tool]))
      throw std::runtime_error(
          "the model cannot take a contact here (too near the clamp, or too far from the surface)");
    attached_[tool] = true;
    return contact(tool);
  }
  void detach(std::uint32_t tool) {
    check_tool(tool);
    model_->detach(tool);
    attached_[tool] = false;
  }
  /// A grasper's jaws close on (true) or open from (false) what the attached tool holds.
  void grasp(std::uint32_t tool, bool closed) {
    check_tool(tool);
    if (!attached_[tool]) throw std::runtime_error("tool " + std::to_string(tool) + " touches nothing to grasp");
    model_->set_grasp(tool, closed);
  }
  py::tuple step(double dt, const py::array_t<double, py::array::c_style | py::array::forcecast>& displacements) {
    if (!(dt > 0.0)) throw std::invalid_argument("dt must be positive, s");
    const std::vector<Eigen::Vector3d> d = displacements_of(displacements, contacts_.size());
    bool ok = false;
    {
      py::gil_scoped_release released;
      ok = model_->step(dt, d.data(), positions_.data(), normals_.data(), contacts_.data());
    }
    if (!ok) throw std::runtime_error("the model could not compute this step (the press is deeper than it can follow)");
    return py::make_tuple(in_file_order(*organ_, positions_), in_file_order(*organ_, normals_));
  }
  /// The force the 1 kHz loop renders for `tool` at displacement d:
  /// F(d) = F0 − K (d − d0), from the last step's linearization.
  Eigen::Vector3d force(std::uint32_t tool, const Eigen::Vector3d& displacement) const {
    check_tool(tool);
    if (!attached_[tool]) throw std::runtime_error(multibeam::describe(multibeam::Status::no_contact));
    const realtime::ContactLinearization& c = contacts_[tool];
    return c.force - c.stiffness * (displacement - c.displacement);
  }
  py::dict contact(std::uint32_t tool) const {
    check_tool(tool);
    if (!attached_[tool]) throw std::runtime_error(multibeam::describe(multibeam::Status::no_contact));
    const realtime::ContactLinearization& c = contacts_[tool];
    py::dict d;
    d["action_point"] = Eigen::Vector3d(c.action_point);
    d["normal"] = Eigen::Vector3d(c.normal);
    d["stiffness"] = Eigen::Matrix3d(c.stiffness);
    d["displacement"] = Eigen::Vector3d(c.displacement);
    d["force"] = Eigen::Vector3d(c.force);
    return d;
  }
  std::string kind() const { return model_->name(); }

 private:
  void check_tool(std::uint32_t tool) const {
    if (tool >= contacts_.size())
      throw std::out_of_range("tool " + std::to_string(tool) + " is out of range: this simulation has tools 0.." +
                              std::to_string(contacts_.size() - 1));
  }
  std::shared_ptr<organ::Organ> organ_;
  std::unique_ptr<realtime::DeformationModel> model_;
  double tip_radius_;  // m
  std::vector<realtime::ContactLinearization> contacts_;
  std::vector<bool> attached_;
  std::vector<model::Point3> positions_, normals_;
};

/// `organsim replay --fast` of a session: the engine's loops stepped
/// deterministically; every force written to each tool's device.
py::dict replay(const Model& model, const std::string& session_path, const std::string& kind, double tip_radius,
                const py::kwargs& settings) {
  const devices::Session session = devices::read_session(session_path);
  realtime::EngineOptions options;
  if (!geometry::ToolTip::valid_radius(tip_radius)) throw std::invalid_argument("tip_radius must be >= 0, m");
  options.tip_radius = tip_radius;
  check_model_name(kind, *model);
  options.model = kind;
  options.models = model_options(settings);
  const organ::Organ organ(*model);
  realtime::PlaybackOptions playback_options;
  playback_options.records_per_tool = realtime::records_for_whole_session(session.duration, options.force_period);
  std::unique_ptr<realtime::SessionPlayback> playback;
  {
    py::gil_scoped_release released;  // the model's set-up and the run
    playback = std::make_unique<realtime::SessionPlayback>(organ, session, options, playback_options);
    playback->run_fast(session.duration);
  }
  const auto& scripted = playback->devices();
  const std::size_t count = scripted.front()->record_count();
  py::array_t<double> times(count), forces({scripted.size(), count, std::size_t{3}});
  py::array_t<bool> in_contact({scripted.size(), count});
  auto t = times.mutable_unchecked<1>();
  auto f = forces.mutable_unchecked<3>();
  auto c = in_contact.mutable_unchecked<2>();
  for (std::size_t i = 0; i < scripted.size(); ++i)
    for (std::size_t r = 0; r < count; ++r) {
      const devices::ForceRecord& record = scripted[i]->record(std::min(r, scripted[i]->record_count() - 1));
      if (i == 0) t(r) = record.time;
      for (py::ssize_t k = 0; k < 3; ++k) f(i, r, k) = record.force[k];
      c(i, r) = record.in_contact;
    }
  py::dict out;
  out["times"] = times;
  out["forces"] = forces;
  out["in_contact"] = in_contact;
  out["duration"] = session.duration;
  return out;
}

/// pipeline::BakeOptions and the option structs it holds, field for field
/// (organsim.bake sets them from its keyword arguments: tools/python/organsim/__init__.py).
void bind_bake_options(py::module_& m) {
  using namespace organsim::pipeline;
  py::class_<SeededSegmentationOptions>(m, "SeededSegmentationOptions")
      .def(py::init<>())
      .def(
          "add_seed",
          [](SeededSegmentationOptions& o, const std::array<double, 3>& mm) {
            o.seeds.push_back(SeedPoint::at_mm(mm));
          },
          py::arg("point_mm"), "A seed inside the organ, X,Y,Z in mm (LPS)")
      .def(
          "add_seed_voxel",
          [](SeededSegmentationOptions& o, const std::array<long, 3>& voxel) {
            o.seeds.push_back(SeedPoint::at_voxel(voxel));
          },
          py::arg("voxel"))
      .def(
          "add_background_seed",
          [](SeededSegmentationOptions& o, const std::array<double, 3>& mm) {
            o.background_seeds.push_back(SeedPoint::at_mm(mm));
          },
          py::arg("point_mm"))
      .def(
          "add_background_seed_voxel",
          [](SeededSegmentationOptions& o, const std::array<long, 3>& voxel) {
            o.background_seeds.push_back(SeedPoint::at_voxel(voxel));
          },
          py::arg("voxel"))
      .def_readwrite("working_spacing_mm", &SeededSegmentationOptions::working_spacing_mm)
      .def_readwrite("smoothing_iterations", &SeededSegmentationOptions::smoothing_iterations)
      .def_readwrite("seed_radius_mm", &SeededSegmentationOptions::seed_radius_mm)
      .def_readwrite("window_sigmas_below", &SeededSegmentationOptions::window_sigmas_below)
      .def_readwrite("window_sigmas_above", &SeededSegmentationOptions::window_sigmas_above)
      .def_readwrite("hu_window", &SeededSegmentationOptions::hu_window)
      .def_readwrite("opening_radius_mm", &SeededSegmentationOptions::opening_radius_mm)
      .def_readwrite("reach_mm", &SeededSegmentationOptions::reach_mm)
      .def_readwrite("closing_radius_mm", &SeededSegmentationOptions::closing_radius_mm)
      .def_readwrite("lesion_radius_mm", &SeededSegmentationOptions::lesion_radius_mm);
  py::class_<SurfaceOptions>(m, "SurfaceOptions")
      .def(py::init<>())
      .def_readwrite("target_vertices", &SurfaceOptions::target_vertices)
      .def_readwrite("smoothing_iterations", &SurfaceOptions::smoothing_iterations)
      .def_readwrite("smoothing_passband", &SurfaceOptions::smoothing_passband)
      .def_readwrite("block_factor", &SurfaceOptions::block_factor);
  py::class_<TetrahedraOptions>(m, "TetrahedraOptions")
      .def(py::init<>())
      .def_readwrite("tet_size_mm", &TetrahedraOptions::tet_size_mm)
      .def_readwrite("facet_distance_mm", &TetrahedraOptions::facet_distance_mm);
  py::class_<BeamBakingOptions>(m, "BeamBakingOptions")
      .def(py::init<>())
      .def_readwrite("stations", &BeamBakingOptions::stations)
      .def_readwrite("samples_per_side", &BeamBakingOptions::samples_per_side)
      .def_readwrite("threads", &BeamBakingOptions::threads);
  py::class_<model::Material>(m, "Material")
      .def(py::init<>())
      .def_readwrite("young_modulus", &model::Material::young_modulus)
      .def_readwrite("poisson_ratio", &model::Material::poisson_ratio)
      .def_readwrite("density", &model::Material::density)
      .def_readwrite("attenuation_alpha", &model::Material::attenuation_alpha)
      .def_readwrite("attenuation_beta", &model::Material::attenuation_beta);
  py::class_<BakeOptions>(
      m, "BakeOptions",
      "organsim bake's options: pipeline::BakeOptions (pipeline/core/include/organsim/pipeline/bake.h)")
      .def(py::init<>())
      .def_readwrite("ct_path", &BakeOptions::ct_path)
      .def_readwrite("series_uid", &BakeOptions::series_uid)
      .def_readwrite("label_path", &BakeOptions::label_path)
      .def_readwrite("label_value", &BakeOptions::label_value)
      .def_readwrite("label_closing_radius_mm", &BakeOptions::label_closing_radius_mm)
      .def_readwrite("seeded", &BakeOptions::seeded)
      .def_readwrite("reference_label_path", &BakeOptions::reference_label_path)
      .def_readwrite("reference_label_value", &BakeOptions::reference_label_value)
      .def_readwrite("fixed_point_mm", &BakeOptions::fixed_point_mm)
      .def_readwrite("fixed_point_voxel", &BakeOptions::fixed_point_voxel)
      .def_readwrite("surface", &BakeOptions::surface)
      .def_readwrite("tetrahedra", &BakeOptions::tetrahedra)
      .def_readwrite("beams", &BakeOptions::beams)
      .def_readwrite("beam_tables", &BakeOptions::beam_tables)
      .def_readwrite("material", &BakeOptions::material)
      .def_readwrite("output_path", &BakeOptions::output_path)
      .def_readwrite("intermediates_dir", &BakeOptions::intermediates_dir);
}

}  // namespace
}  // namespace organsim::python

PYBIND11_MODULE(_organsim, m) {
  using namespace organsim;
  using namespace organsim::python;
  m.doc() = "organsim: patient-specific organ models from CT and their real-time deformation (SI units)";
  m.attr("__version__") = kProgramVersion;
  py::register_exception<std::runtime_error>(m, "Error", PyExc_RuntimeError);

  py::class_<OrganModel, Model>(m, "Model",
                                "A loaded .organ model; its arrays are read-only "
                                "views of its memory (m, the file's order)")
      .def_property_readonly(
          "surface_vertices",
          [](py::object self) {
            const auto& v = self.cast<const OrganModel&>().surface_vertices;
            return view(v.empty() ? nullptr : v.front().data(), v.size(), 3, self);
          },
          "(N, 3) float64: the simulation surface's rest vertices, m")
      .def_property_readonly(
          "surface_triangles",
          [](py::object self) {
            const auto& t = self.cast<const OrganModel&>().surface_triangles;
            return view(t.empty() ? nullptr : t.front().data(), t.size(), 3, self);
          },
          "(M, 3) uint32: counter-clockwise seen from outside")
      .def_property_readonly(
          "volume_vertices",
          [](py::object self) {
            const auto& v = self.cast<const OrganModel&>().volume_vertices;
            return view(v.empty() ? nullptr : v.front().data(), v.size(), 3, self);
          },
          "(K, 3) float64: the tetrahedral mesh's nodes, m")
      .def_property_readonly(
          "tetrahedra",
          [](py::object self) {
            const auto& t = self.cast<const OrganModel&>().tetrahedra;
            return view(t.empty() ? nullptr : t.front().data(), t.size(), 4, self);
          },
          "(T, 4) uint32: positively oriented")
      .def_property_readonly(
          "fixed_points",
          [](py::object self) {
            const auto& p = self.cast<const OrganModel&>().fixed_points;
            return view(p.empty() ? nullptr : p.front().data(), p.size(), 3, self);
          },
          "(F, 3) float64: the beams' clamp, m")
      .def_property_readonly(
          "beam_sections",
          [](py::object self) {
            const OrganModel& model = self.cast<const OrganModel&>();
            static_assert(sizeof(model::BeamSection) == 7 * sizeof(double));
            const std::size_t stations = model.beams.stations_per_beam;
            const std::size_t vertices = stations == 0 ? 0 : model.beams.sections.size() / stations;
            const double* data = model.beams.sections.empty() ? nullptr : &model.beams.sections.front().area;
            return read_only(py::array(py::dtype::of<double>(), {vertices, stations, std::size_t{7}},
                                       {stations * 7 * sizeof(double), 7 * sizeof(double), sizeof(double)}, data,
                                       self));
          },
          "(N, S, 7) float64: per surface vertex and station: area m², i_yy, i_zz, i_yz m⁴, torsion J m⁴, "
          "centroid y, z m (beam_section_fields)")
      .def_property_readonly("material",
                             [](const OrganModel& model) {
                               const model::Material& mat = model.material;
                               py::dict d;
                               d["young_modulus_pa"] = mat.young_modulus;
                               d["poisson_ratio"] = mat.poisson_ratio;
                               d["density_kg_m3"] = mat.density;
                               d["attenuation_alpha"] = mat.attenuation_alpha;
                               d["attenuation_beta_per_m"] = mat.attenuation_beta;
                               d["beam_stiffness_scale"] = mat.beam_stiffness_scale;
                               d["spring_stiffness_scale"] = mat.spring_stiffness_scale;
                               return d;
                             })
      .def_property_readonly("provenance",
                             [](const OrganModel& model) {
                               py::dict d;
                               d["coordinate_frame"] = model.provenance.coordinate_frame;
                               d["program_version"] = model.provenance.program_version;
                               d["input_sha256"] = model.provenance.input_sha256;
                               d["parameters"] = model.provenance.parameters;
                               return d;
                             })
      .def("__repr__", [](const OrganModel& model) {
        return "<organsim.Model: " + std::to_string(model.surface_vertices.size()) + " surface vertices, " +
               std::to_string(model.tetrahedra.size()) + " tetrahedra, " +
               std::to_string(model.beams.stations_per_beam) + " beam stations>";
      });
  m.attr("beam_section_fields") =
      py::make_tuple("area_m2", "i_yy_m4", "i_zz_m4", "i_yz_m4", "torsion_j_m4", "centroid_y_m", "centroid_z_m");

  m.def("_load", &load, py::arg("path"), "Reads a .organ model file (checked: a bad file raises organsim.Error)");
  bind_bake_options(m);
  m.def("_bake", &cli::bake_report_json, py::arg("options"), py::call_guard<py::gil_scoped_release>(),
        "Bakes with these options (output_path set) -> the report as `organsim bake --json` prints it");

  py::class_<MultiBeamModel>(m, "MultiBeam", "The multi-beam model (Ushiki et al.): one beam per tool, m and N")
      .def(py::init<const Model&, std::uint32_t, const std::string&, const std::string&>(), py::arg("model"),
           py::arg("max_tools") = 4, py::arg("merge") = "influence", py::arg("theory") = "euler-bernoulli")
      .def_property_readonly("max_tools", &MultiBeamModel::max_tools)
      .def("attach", &MultiBeamModel::attach, py::arg("tool"), py::arg("point"),
           "Contact begins: snaps the point (m) to the surface and builds the tool's beam")
      .def("detach", &MultiBeamModel::detach, py::arg("tool"))
      .def("action_point", &MultiBeamModel::action_point, py::arg("tool"))
      .def("stiffness", &MultiBeamModel::stiffness, py::arg("tool"), "The tip stiffness K (3x3, N/m)")
      .def("force", &MultiBeamModel::force, py::arg("tool"), py::arg("tip_displacement"),
           "Force on the tool (N) for its action point displaced (m): -K d")
      .def("deform", &MultiBeamModel::deform, py::arg("tip_displacements"),
           "(max_tools, 3) tip displacements (m; rows of detached tools ignored) -> (positions, normals), each (N, 3) "
           "in the model file's vertex order");

  py::class_<Simulation>(
      m, "Simulation",
      ("Any deformation model through the real-time engine's interface: " + realtime::model_names(", ")).c_str())
      .def(py::init<const Model&, const std::string&, std::uint32_t, double, const py::kwargs&>(), py::arg("model"),
           py::arg("kind") = realtime::default_model().name, py::arg("tools") = 1, py::arg("tip_radius") = 2.5e-3,
           ("tip_radius: the tools' hemispherical end, m (0: a point tool; docs/realtime.md#contact-rule). " +
            settings_help())
               .c_str())
      .def_property_readonly("kind", &Simulation::kind)
      .def("attach", &Simulation::attach, py::arg("tool"), py::arg("rest_point"), py::arg("shaft") = py::none(),
           "Contact begins where the tool's tip touches a rest-surface point (m); shaft: unit direction from the tip "
           "to the handle (default: the surface's outward normal there). Returns the contact's linearization")
      .def("detach", &Simulation::detach, py::arg("tool"))
      .def("grasp", &Simulation::grasp, py::arg("tool"), py::arg("closed") = true,
           "A grasper's jaws close on (True) or open from (False) what the attached tool holds: held, the contact "
           "holds both ways and may pull (docs/realtime.md#grasping)")
      .def("step", &Simulation::step, py::arg("dt"), py::arg("displacements"),
           "Advances dt s with (tools, 3) contact displacements (m) -> (positions, normals) (N, 3), file order")
      .def("force", &Simulation::force, py::arg("tool"), py::arg("displacement"),
           "What the 1 kHz loop renders: F0 - K (d - d0) from the last step, N")
      .def("contact", &Simulation::contact, py::arg("tool"));

  m.def("_replay", &replay, py::arg("model"), py::arg("session"), py::arg("kind") = realtime::default_model().name,
        py::arg("tip_radius") = 2.5e-3,
        "organsim replay --fast: forces (tools, R, 3) N at times (R,) s, in_contact (tools, R)");
}
