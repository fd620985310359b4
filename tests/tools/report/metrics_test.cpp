// The training report's metrics from raw data written by hand: the measures
// whose inputs a session cannot set exactly (the surface's strain).
#include "report/training_report.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "temp_directory.h"

namespace organsim::report {
namespace {

namespace fs = std::filesystem;

// Two triangles of the surface, one stretched by 50 % once in the run, the
// other by 10 %; a tool held still for 0.1 s, never touching.
void write_run(const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream(dir / "run.json") << R"({"tools": 1, "duration_s": 0.1, "rest_volume_ml": 1.0})";
  std::ofstream ticks(dir / "ticks.csv");
  ticks << "t_s,tool,fx_n,fy_n,fz_n,model_force_n,in_contact,x_mm,y_mm,z_mm,depth_mm,pose_valid,jaws_closed,grasped,"
           "grasp_slipped\n";
  for (int k = 0; k <= 100; ++k) ticks << 0.001 * k << ",1,0,0,0,0,0,5,5,50,0,1,0,0,0\n";
  std::ofstream(dir / "frames.csv") << "t_s,volume_ml\n0,1\n0.1,1\n";
  // A 10 mm × 10 mm square in z = 0 split along its diagonal: 50 mm² each.
  std::ofstream(dir / "surface.csv") << "x_mm,y_mm,z_mm,peak_indentation_mm\n0,0,0,0\n10,0,0,0\n10,10,0,0\n0,10,0,0\n";
  std::ofstream(dir / "triangles.csv") << "a,b,c,peak_strain\n0,1,2,0.5\n0,2,3,0.1\n";
}

using ReportMetrics = testing::TempDirectoryTest;

TEST_F(ReportMetrics, TheSurfaceStrainedBeyondTheLimitIsTheAreaOfItsTriangles) {
  write_run(dir_);
  const RunMetrics m = compute_metrics(dir_.string(), kDefaultForceLimit);
  EXPECT_DOUBLE_EQ(m.largest_strain, 0.5);
  EXPECT_DOUBLE_EQ(m.damaged_area_mm2, 50.0) << "only the triangle stretched by 50 % is beyond 30 %";
  const RunMetrics strict = compute_metrics(dir_.string(), kDefaultForceLimit, 0.05);
  EXPECT_DOUBLE_EQ(strict.damaged_area_mm2, 100.0);
  // The still tool: 0.1 s idle (ten 10 ms intervals), no path, no jerk.
  ASSERT_EQ(m.tools.size(), 1u);
  EXPECT_NEAR(m.tools[0].idle_time_s, 0.1, 1e-9);
  EXPECT_DOUBLE_EQ(m.tools[0].path_length_mm, 0.0);
  EXPECT_DOUBLE_EQ(m.tools[0].mean_squared_jerk, 0.0);
  EXPECT_DOUBLE_EQ(m.tools[0].economy_of_motion, 1.0);
  EXPECT_THROW(compute_metrics(dir_.string(), kDefaultForceLimit, 0.0), std::runtime_error);
}

}  // namespace
}  // namespace organsim::report
