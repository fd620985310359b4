// `organsim poke`: the forces of a baked cylinder against beam theory, the JSON
// keys, and bad tool arguments.
#include <gtest/gtest.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "organsim/pipeline/image_io.h"
#include "press_plan.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

// A CT of 1 mm voxels over `size` from `origin` (mm): tissue 60 HU where
// `inside(x, y, z)` (mm), −100 HU fat elsewhere; and its label map.
template <typename Inside>
void write_solid_ct(const fs::path& ct_path, const fs::path& label_path, const std::array<itk::SizeValueType, 3>& size,
                    const std::array<double, 3>& origin, Inside inside) {
  pipeline::CtImage::Pointer ct = pipeline::CtImage::New();
  pipeline::MaskImage::Pointer label = pipeline::MaskImage::New();
  pipeline::CtImage::RegionType region;
  region.SetSize({size[0], size[1], size[2]});
  ct->SetRegions(region);
  label->SetRegions(region);
  ct->SetOrigin(origin.data());
  label->SetOrigin(origin.data());
  ct->Allocate();
  label->Allocate();
  for (itk::IndexValueType k = 0; k < static_cast<itk::IndexValueType>(size[2]); ++k)
    for (itk::IndexValueType j = 0; j < static_cast<itk::IndexValueType>(size[1]); ++j)
      for (itk::IndexValueType i = 0; i < static_cast<itk::IndexValueType>(size[0]); ++i) {
        const bool in = inside(origin[0] + i, origin[1] + j, origin[2] + k);
        ct->SetPixel({i, j, k}, static_cast<std::int16_t>(in ? 60 : -100));
        label->SetPixel({i, j, k}, in ? 1 : 0);
      }
  pipeline::write_ct_image(*ct, ct_path.string());
  pipeline::write_mask_image(*label, label_path.string());
}

// A solid cylinder CT: radius 25 mm, along x from x = 0 to x = 150 mm.
void write_cylinder_ct(const fs::path& ct_path, const fs::path& label_path) {
  constexpr double kRadius = 25.0, kLength = 150.0;
  write_solid_ct(ct_path, label_path, {170, 70, 70}, {-10.0, -34.5, -34.5}, [](double x, double y, double z) {
    return x >= 0.0 && x <= kLength && y * y + z * z <= kRadius * kRadius;
  });
}

/// The cylinder CT baked into `model`, clamped at the centre of the x = 0 cap.
CommandRun bake_cylinder(const fs::path& dir, const std::string& model) {
  const fs::path ct = dir / "cylinder_ct.nii.gz", label = dir / "cylinder_label.nii.gz";
  write_cylinder_ct(ct, label);
  return run_organsim(
      "bake " + ct.string() + " --label " + label.string() + " --fixed-point 0,0,0 --surface-vertices 4000 -o " + model,
      dir);
}

TEST_F(Cli, PokeABakedCylinderGivesTheCantileverForces) {
  // CT → bake (clamped at the centre of the x = 0 cap) → poke the far cap:
  // transverse 3EIδ/L³ and axial EAδ/L of a circular beam, within a few percent
  // (the voxelized, smoothed surface is the only approximation). The beam's
  // own force (--unmatched), not the FEM reference's site law. The cap is
  // held as a grasp holds it (--friction inf): a press across the surface
  // would otherwise slip. A point load, as beam theory's (--tip-radius 0).
  const std::string model = (dir_ / "cylinder.organ").string();
  const CommandRun bake = bake_cylinder(dir_, model);
  ASSERT_EQ(bake.exit_code, 0) << bake.err;

  const double e = 5000.0, radius = 0.025, delta = 0.005;
  const double area = M_PI * radius * radius, inertia = M_PI * std::pow(radius, 4) / 4.0;
  const CommandRun transverse =
      run_organsim("poke " + model + " --tool 151,0,0/0,5,0 --json --unmatched --friction inf --tip-radius 0", dir_);
  ASSERT_EQ(transverse.exit_code, 0) << transverse.err;
  const nlohmann::json t = nlohmann::json::parse(transverse.out);
  const double length = t["tools"][0]["beam_length_mm"].get<double>() * 1e-3;
  EXPECT_NEAR(length, 0.150, 0.002);
  const double expected_transverse = 3.0 * e * inertia * delta / std::pow(length, 3);
  EXPECT_NEAR(-t["tools"][0]["force_n"][1].get<double>(), expected_transverse, 0.04 * expected_transverse);
  // The action point lies inside a triangle, so no vertex moves the full 5 mm.
  EXPECT_LE(t["organ"]["max_displacement_mm"].get<double>(), 5.0 + 1e-9);
  EXPECT_GT(t["organ"]["max_displacement_mm"].get<double>(), 3.0);

  const CommandRun axial =
      run_organsim("poke " + model + " --tool 151,0,0/-5,0,0 --json --unmatched --tip-radius 0", dir_);
  ASSERT_EQ(axial.exit_code, 0) << axial.err;
  const nlohmann::json a = nlohmann::json::parse(axial.out);
  const double expected_axial = e * area * delta / length;
  EXPECT_NEAR(a["tools"][0]["force_n"][0].get<double>(), expected_axial, 0.04 * expected_axial);
  EXPECT_LT(std::abs(a["tools"][0]["force_n"][1].get<double>()), 0.05 * expected_axial);
  std::printf("baked cylinder: transverse force %+.2f %%, axial force %+.2f %% from the analytic values\n",
              100.0 * (-t["tools"][0]["force_n"][1].get<double>() / expected_transverse - 1.0),
              100.0 * (a["tools"][0]["force_n"][0].get<double>() / expected_axial - 1.0));
}

TEST_F(Cli, BakedCylinderBeamAndCorotationalFemForcesAgreeWithinBeamTheory) {
  // The baked cylinder (radius a = 25 mm, L = 150 mm, a/L = 1/6) pressed 5 mm
  // across at the far cap, by the beam and by the co-rotational FEM with every
  // node within R = 26 mm of the cap centre clamped. Beam theory's expected
  // error for this slenderness: Euler-Bernoulli leaves out shear, which adds
  // 3EI/(kGAL^2) = 2.4 (a/L)^2 = 6.7 % to the compliance (k = 0.90, nu = 0.45);
  // Timoshenko's beam includes it. And the FEM's clamp is a ball, not the
  // x = 0 plane: its surface crosses the cylinder between sqrt(R^2 - a^2) =
  // 7.1 mm (the rim) and R = 26 mm (the axis) from the cap, so the FEM's
  // cantilever is that much shorter. Each beam's force must lie between the
  // forces its theory gives for those two lengths, scaled to the beam's own
  // length: F_beam / F_fem in [k(L) / k(L - 26 mm), k(L) / k(L - 7.1 mm)].
  const std::string model = (dir_ / "cylinder.organ").string();
  const CommandRun bake = bake_cylinder(dir_, model);
  ASSERT_EQ(bake.exit_code, 0) << bake.err;
  const double e = 5000.0, nu = 0.45, a = 0.025, length = 0.151, ball = 0.026;
  const double shear_factor = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu);  // circular section
  const double inertia = M_PI * std::pow(a, 4) / 4.0, area = M_PI * a * a, g = e / (2.0 * (1.0 + nu));
  auto stiffness = [&](const std::string& theory, double l) {
    const double bending = l * l * l / (3.0 * e * inertia);
    return 1.0 / (theory == "timoshenko" ? bending + l / (shear_factor * g * area) : bending);
  };
  for (const std::string theory : {"euler-bernoulli", "timoshenko"}) {
    // A point load at the free end, as beam theory has it (--tip-radius 0).
    const CommandRun run =
        run_organsim("compare " + model +
                         " --tool 151,0,0/0,5,0 --models beam,corotational "
                         "--reference corotational --fixed-radius 26 --tip-radius 0 --friction inf --json "
                         "--theory " +
                         theory,
                     dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const nlohmann::json j = nlohmann::json::parse(run.out);
    const double beam = -j["models"]["beam"]["forces_n"][0][1].get<double>();
    const double fem = -j["models"]["corotational"]["forces_n"][0][1].get<double>();
    const double low = stiffness(theory, length) / stiffness(theory, length - ball);
    const double high = stiffness(theory, length) / stiffness(theory, length - std::sqrt(ball * ball - a * a));
    std::printf(
        "baked cylinder, %s beam vs co-rotational FEM tip force: %.5f / %.5f N = %.3f (expected %.3f to %.3f)\n",
        theory.c_str(), beam, fem, beam / fem, low, high);
    EXPECT_GT(beam / fem, low) << theory;
    EXPECT_LT(beam / fem, high) << theory;
  }
}

TEST_F(Cli, PokeJsonHasTheDocumentedKeysAndWritesTheDeformedSurface) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string out = (dir_ / "deformed.vtp").string();
  const CommandRun run = run_organsim(
      "poke " + model + " --tool 150,0,0/0,5,0 --tool 80,31,0/0,-3,0 --merge sum --json --out " + out, dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["merge"], "sum");
  EXPECT_EQ(j["theory"], "euler-bernoulli");
  ASSERT_EQ(j["tools"].size(), 2u);
  for (const char* key : {"point_mm", "action_point_mm", "snap_distance_mm", "beam_length_mm", "displacement_mm",
                          "force_n", "force_magnitude_n"})
    EXPECT_TRUE(j["tools"][1].contains(key)) << key;
  EXPECT_NEAR(j["tools"][1]["snap_distance_mm"].get<double>(), 1.0, 0.1);  // 31 mm → the 30 mm wall
  for (const char* key : {"vertices", "max_displacement_mm", "max_displacement_vertex", "rest_volume_ml",
                          "deformed_volume_ml", "volume_change_percent"})
    EXPECT_TRUE(j["organ"].contains(key)) << key;
  for (const char* key : {"beam_per_tool", "force_per_tool", "deformation"})
    EXPECT_TRUE(j["seconds"].contains(key)) << key;
  EXPECT_TRUE(j["tools"][0]["held_points"].is_null()) << "the beam holds no boundary points";
  EXPECT_TRUE(j["contact_points_left_out"].is_null());
  EXPECT_TRUE(fs::exists(out));
  // A FEM model says how finely its tip's contact is resolved.
  const CommandRun fem =
      run_organsim("poke " + model + " --model linear --fixed-radius 31 --tool 150,0,0/-3,0,0 --json", dir_);
  ASSERT_EQ(fem.exit_code, 0) << fem.err;
  const nlohmann::json f = nlohmann::json::parse(fem.out);
  EXPECT_GE(f["tools"][0]["held_points"].get<int>(), 1);
  EXPECT_EQ(f["contact_points_left_out"], 0);
  const CommandRun text = run_organsim("poke " + model + " --tool 150,0,0/0,5,0 --friction inf", dir_);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("force on the tool"), std::string::npos);
  EXPECT_NE(text.out.find("|F| 0.0141 N"), std::string::npos) << text.out;  // 3EIδ/L³ of the helper cylinder
}

// `poke --grasp 3`: each tool bites 3 mm in along the inward normal, closes
// its jaws and then moves to its displacement; pulled 5 mm out of the
// cylinder's side, the organ follows and pulls the tool back in every model,
// and nothing slips (docs/realtime.md#grasping).
TEST_F(Cli, PokeWithAGraspPullsTheOrganOutInEveryModel) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  for (const char* name : {"beam", "springs", "linear", "corotational", "stvk", "psh"}) {
    const CommandRun run = run_organsim(
        fmt::format("poke {} --tool 80,30,0/0,5,0 --grasp 3 --model {} --fixed-radius 31 --json", model, name), dir_);
    ASSERT_EQ(run.exit_code, 0) << name << ": " << run.err;
    const nlohmann::json j = nlohmann::json::parse(run.out);
    const nlohmann::json& tool = j["tools"][0];
    EXPECT_LT(tool["force_n"][1].get<double>(), -1e-3) << name << ": the organ pulls the tool back";
    for (int k = 0; k < 3; ++k) EXPECT_EQ(tool["slip_mm"][k].get<double>(), 0.0) << name;
    EXPECT_GT(j["organ"]["max_displacement_mm"].get<double>(), 3.0) << name << ": the side follows the jaws";
  }
  const CommandRun zero = run_organsim("poke " + model + " --tool 80,30,0/0,5,0 --grasp 0", dir_);
  EXPECT_NE(zero.exit_code, 0) << "a grasp bites in: --grasp takes a positive depth";
}

TEST_F(Cli, PokeWithTheSpringModelPushesBackHarderTheDeeperItPresses) {
  // The same press through the mass-spring model: the organ settles under the
  // held node, and the force opposes the press and grows with its depth.
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  std::array<double, 2> pushed{};
  for (int depth = 1; depth <= 2; ++depth) {
    const CommandRun run =
        run_organsim("poke " + model + fmt::format(" --tool 80,30,0/0,{},0 --model springs --json", -2 * depth), dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const nlohmann::json j = nlohmann::json::parse(run.out);
    EXPECT_EQ(j["deformation_model"], "springs");
    EXPECT_TRUE(j["tools"][0]["beam_length_mm"].is_null());
    EXPECT_EQ(j["seconds"]["frames"], 120);  // 2 s of 1/60 s frames by default
    const std::vector<double> force = j["tools"][0]["force_n"];
    pushed[depth - 1] = force[1];  // the press goes along −y: the organ pushes back along +y
    EXPECT_GT(force[1], 0.0) << run.out;
    EXPECT_LT(std::abs(force[0]) + std::abs(force[2]), force[1]) << run.out;
    EXPECT_NEAR(j["organ"]["max_displacement_mm"].get<double>(), 2.0 * depth, 0.5) << run.out;
  }
  // Nearly linear for small presses: twice as deep, about twice the force.
  EXPECT_NEAR(pushed[1] / pushed[0], 2.0, 0.3);
}

// A depth curve is fitted for one tip radius (organsim calibrate): a matched
// fast model pressing with a tool of another radius reads it rescaled, and
// says so; not at the radius it was fitted for, with a point tool (no site
// law), with --unmatched, or for a FEM model (neither reads the curve).
TEST_F(Cli, ADepthCurveFittedForAnotherTipRadiusIsNamedWhenItIsRescaled) {
  model::OrganModel cylinder = testing::make_cylinder_model({});
  testing::add_uniform_site_compliance(cylinder, 0.05);  // its depth curve fitted for a 2.5 mm tip
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(cylinder, model);
  const CommandRun other = run_organsim("poke " + model + " --tool 80,30,0/0,-3,0 --tip-radius 4", dir_);
  ASSERT_EQ(other.exit_code, 0) << other.err;
  const std::string warning = "the model's depth curve was fitted for a 2.5 mm tip, and a tool's is 4 mm";
  EXPECT_NE(other.err.find(warning), std::string::npos) << other.err;
  for (const char* options : {" --tool 80,30,0/0,-3,0 --tip-radius 2.5", " --tool 80,30,0/0,-3,0 --tip-radius 0",
                              " --tool 80,30,0/0,-3,0 --tip-radius 4 --unmatched",
                              " --tool 150,0,30/0,0,-3 --tip-radius 4 --model linear --fixed-radius 31"}) {
    const CommandRun quiet = run_organsim("poke " + model + options, dir_);
    ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
    EXPECT_EQ(quiet.err.find("depth curve"), std::string::npos) << options << ": " << quiet.err;
  }
}

TEST_F(Cli, APressOutsideTheFrictionConeSlipsOntoItAndAGraspHolds) {
  // The engine's contact rule in a static press (docs/realtime.md#contact-rule):
  // the helper cylinder's side (outward normal +y) pressed 1 mm in and 3 mm
  // along its axis, where the organ is far stiffer than across it: held, the
  // force lies outside Coulomb's cone (μ = 0.2). The organ slips under the
  // tool until the force is back inside it (on its boundary, or within it
  // where the slip also turned a pull into a push), the slip within the
  // side's tangent plane, mostly along the press's tangential part; with --friction
  // inf nothing slips and the force is the held press's. For every kind of model.
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  for (const char* name : {"beam", "springs", "linear"}) {
    const std::string press =
        "poke " + model + " --tool 80,30,0/3,-1,0 --model " + name + " --fixed-radius 31 --unmatched --json";
    const CommandRun slipping = run_organsim(press, dir_);
    const CommandRun held = run_organsim(press + " --friction inf", dir_);
    ASSERT_EQ(slipping.exit_code, 0) << name << ": " << slipping.err;
    ASSERT_EQ(held.exit_code, 0) << name << ": " << held.err;
    const nlohmann::json s = nlohmann::json::parse(slipping.out)["tools"][0];
    const nlohmann::json h = nlohmann::json::parse(held.out)["tools"][0];
    const std::vector<double> force = s["force_n"], slip = s["slip_mm"], held_force = h["force_n"],
                              held_slip = h["slip_mm"];
    const double normal = force[1], tangential = std::hypot(force[0], force[2]);
    EXPECT_GT(normal, 0.0) << name;  // the organ pushes the tool out of its side
    EXPECT_LE(tangential, 0.2 * normal * (1.0 + 1e-3)) << name;
    EXPECT_NEAR(slip[1], 0.0, 1e-9) << name;  // within the tangent plane
    EXPECT_GT(slip[0], 0.5) << name;          // mostly along the press's tangential part, mm
    EXPECT_LE(slip[0], 3.0 + 1e-6) << name;
    EXPECT_EQ(held_slip, (std::vector<double>{0.0, 0.0, 0.0})) << name;
    EXPECT_GT(std::hypot(held_force[0], held_force[2]), 0.2 * std::max(held_force[1], 0.0))
        << name << ": the held press leaves the cone";
    std::printf("%s: held (%.4f, %.4f) N -> slipped by %.2f mm: (%.4f, %.4f) N\n", name, held_force[0], held_force[1],
                slip[0], force[0], force[1]);
  }
}

TEST_F(Cli, APressWhoseShaftWouldPierceTheOrganElsewhereIsRefusedAndCalibrateNeverMakesOne) {
  // A step: a slab (x 0-100 mm, z up to 20 mm) with a tower on its far end
  // (x 60-100 mm, z up to 55 mm) whose roof (z 45-55 mm) overhangs the floor
  // back to x = 40 mm. The floor pressed 30 mm before the tower, tilted 45°
  // toward it: the shaft leans over the tower and passes through it. The
  // press cannot be made, and poke says so for every model before any runs;
  // tilted the other way it is made. Under the roof no tool can press
  // straight in: calibrate's sites avoid it, and its tilted presses turn to
  // a side the shaft is clear of.
  const fs::path ct = dir_ / "step_ct.nii.gz", label = dir_ / "step_label.nii.gz";
  write_solid_ct(ct, label, {120, 60, 100}, {-10.0, -29.5, -29.5}, [](double x, double y, double z) {
    const bool slab = x >= 0.0 && x <= 100.0 && z >= -20.0 && z <= 20.0;
    const bool tower = x >= 60.0 && x <= 100.0 && z >= -20.0 && z <= 55.0;
    const bool roof = x >= 40.0 && x <= 100.0 && z >= 45.0 && z <= 55.0;
    return std::abs(y) <= 20.0 && (slab || tower || roof);
  });
  const std::string model = (dir_ / "step.organ").string();
  const CommandRun bake = run_organsim(
      "bake " + ct.string() + " --label " + label.string() + " --fixed-point 0,0,0 --surface-vertices 3000 -o " + model,
      dir_);
  ASSERT_EQ(bake.exit_code, 0) << bake.err;
  for (const char* name : {"springs", "linear"}) {
    const CommandRun toward = run_organsim("poke " + model + " --tool 30,0,20/-3.5,0,-3.5 --model " + name, dir_);
    EXPECT_EQ(toward.exit_code, 1) << name;
    EXPECT_NE(toward.err.find("its shaft, 45 degrees from the surface normal, would pass through the organ"),
              std::string::npos)
        << name << ": " << toward.err;
    EXPECT_NE(toward.err.find("press closer to the normal or from another side"), std::string::npos) << toward.err;
    const CommandRun away = run_organsim("poke " + model + " --tool 30,0,20/3.5,0,-3.5 --model " + name, dir_);
    EXPECT_EQ(away.exit_code, 0) << name << ": " << away.err;
  }
  const CommandRun under_roof = run_organsim("poke " + model + " --tool 50,0,20/0,0,-2 --model springs", dir_);
  EXPECT_EQ(under_roof.exit_code, 1);
  EXPECT_NE(under_roof.err.find("0 degrees from the surface normal"), std::string::npos) << under_roof.err;

  model::ModelReadResult read = model::read_organ_model_file(model);
  ASSERT_TRUE(read) << read.error;
  const organ::Organ step(std::move(*read.model));
  cli::PressOptions press;
  const std::vector<Eigen::Vector3d> normals = cli::rest_normals(step);
  int picked_under_roof = 0;
  for (const std::uint32_t site : cli::press_sites(step, 40, 1, press)) {
    const Eigen::Vector3d at = 1e3 * cli::site_point(step, site);
    // The floor under the roof, and the roof's underside above it.
    picked_under_roof += at[0] > 41.0 && at[0] < 59.0 && (std::abs(at[2] - 20.0) < 1.5 || std::abs(at[2] - 45.0) < 1.5);
    for (const cli::PressTilt tilt : {cli::PressTilt::straight, cli::PressTilt::tangent_a, cli::PressTilt::tangent_b}) {
      const cli::ToolSpec tool = cli::site_press(step, site, normals[site], tilt, 2.0, press);
      const Eigen::Vector3d point = tool.point_mm * 1e-3, by = tool.displacement_mm * 1e-3;
      EXPECT_TRUE(std::isinf(cli::shaft_entry(step, point, cli::press_tip(step, point, by, press)))) << tool.text;
    }
  }
  EXPECT_EQ(picked_under_roof, 0);
}

TEST_F(Cli, PokeWithFemModelsAndTheirDifferenceFromTheBeams) {
  // The helper cylinder's tetrahedra clamped over the x = 0 cap (31 mm): a
  // press of the far cap's rim. Every FEM model pushes back against the press;
  // the nearly incompressible psh keeps the volume better than linear (ν 0.45);
  // --compare prints the second model's forces and the surfaces' distance.
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  std::map<std::string, nlohmann::json> runs;
  for (const char* name : {"linear", "corotational", "stvk", "psh"}) {
    const CommandRun run =
        run_organsim("poke " + model + " --tool 150,0,30/0,0,-5 --model " + name + " --fixed-radius 31 --json", dir_);
    ASSERT_EQ(run.exit_code, 0) << name << ": " << run.err;
    runs[name] = nlohmann::json::parse(run.out);
    const std::vector<double> force = runs[name]["tools"][0]["force_n"];
    EXPECT_GT(force[2], 0.0) << name;  // pressed along −z: pushed back along +z
    EXPECT_GE(runs[name]["seconds"]["frames"].get<int>(), 1) << name;
  }
  EXPECT_LE(runs["linear"]["seconds"]["frames"], 1);  // linear: one Newton iteration is the solution
  EXPECT_LT(std::abs(runs["psh"]["organ"]["volume_change_percent"].get<double>()),
            std::abs(runs["linear"]["organ"]["volume_change_percent"].get<double>()));

  const CommandRun text =
      run_organsim("poke " + model + " --tool 150,0,30/0,0,-5 --model psh --fixed-radius 31 --compare beam", dir_);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  for (const char* expected : {"psh: ", "Newton", "compare       beam", "|F_psh - F_beam|", "surfaces psh vs beam"})
    EXPECT_NE(text.out.find(expected), std::string::npos) << expected << "\n" << text.out;
  const CommandRun json = run_organsim(
      "poke " + model + " --tool 150,0,30/0,0,-5 --model linear --fixed-radius 31 --compare springs --json", dir_);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json j = nlohmann::json::parse(json.out);
  for (const char* key : {"deformation_model", "tools", "surface_difference_rms_mm", "surface_difference_max_mm"})
    EXPECT_TRUE(j["compare"].contains(key)) << key;
  EXPECT_GT(j["compare"]["surface_difference_max_mm"].get<double>(), 0.0);

  const CommandRun clamp = run_organsim("poke " + model + " --tool 150,0,30/0,0,-5 --model psh", dir_);
  EXPECT_EQ(clamp.exit_code, 1);
  EXPECT_NE(clamp.err.find("raise the clamp radius"), std::string::npos) << clamp.err;
  const CommandRun same = run_organsim("poke " + model + " --tool 150,0,30/0,0,-5 --model psh --compare psh", dir_);
  EXPECT_EQ(same.exit_code, 2) << same.err;
}

TEST_F(Cli, PokeBadInputsFailWithOneLine) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--tool nan,0,0/0,5,0", "NaN"},
      {"--tool 150,0,0/inf,5,0", "NaN or infinite"},
      {"--tool 500,500,500/0,5,0", "farther from the organ surface"},
      {"--tool 0,0,0/0,5,0", "fixed point"},
      {"--tool 150,0,0", "X,Y,Z/DX,DY,DZ"},
      {"--tool 150,0/0,5,0", "X,Y,Z/DX,DY,DZ"},
      {"--tool 150,a,0/0,5,0", "not a number"},
      {"--tool 150,0,0/0,5,0 --out deformed.stl", ".vtp"},
  };
  for (const auto& [arguments, message] : cases) {
    const CommandRun run = run_organsim("poke " + model + " " + arguments, dir_);
    EXPECT_EQ(run.exit_code, 1) << arguments;
    EXPECT_NE(run.err.find(message), std::string::npos) << arguments << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  }
  const CommandRun missing = run_organsim("poke " + (dir_ / "absent.organ").string() + " --tool 1,2,3/0,0,1", dir_);
  EXPECT_EQ(missing.exit_code, 1);
  // Two tools at the same point are merged, not an error (held: the press is across the surface).
  const CommandRun same =
      run_organsim("poke " + model + " --tool 150,0,0/0,5,0 --tool 150,0,0/0,5,0 --friction inf --json", dir_);
  ASSERT_EQ(same.exit_code, 0) << same.err;
  // Within the single-precision distortion's 10 nm (docs/multibeam.md).
  EXPECT_NEAR(nlohmann::json::parse(same.out)["organ"]["max_displacement_mm"].get<double>(), 5.0, 1e-5);
}

}  // namespace
}  // namespace organsim
