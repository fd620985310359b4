// Every instruction-set level of the per-vertex kernels that this CPU runs
// computes the same vertices (the levels differ only in rounding: FMA, lane
// order).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "organsim/vertex_kernels/vertex_kernels.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/organ/organ.h"
#include "test_models.h"

namespace organsim::multibeam {
namespace {

double largest_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

TEST(MultiBeamKernels, TheSelectedLevelIsTheWidestThisCpuRuns) {
  const vertex_kernels::RunnableSets sets = vertex_kernels::runnable();
  ASSERT_GE(sets.count, 1u);
  EXPECT_STREQ(vertex_kernels::selected().level, sets.set[0].level);
  EXPECT_EQ(vertex_kernels::selected().distort, sets.set[0].distort);
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX2__)
  // The portable build: the baseline is always compiled and always runs.
  EXPECT_STREQ(sets.set[sets.count - 1].level, "x86-64");
  if (__builtin_cpu_supports("x86-64-v4")) {
    EXPECT_STREQ(sets.set[0].level, "x86-64-v4");
  }
#endif
}

TEST(MultiBeamKernels, EveryLevelComputesTheSameWeightsDistortionAndNormals) {
  const organ::Organ sphere(testing::make_sphere_model(2400, 20));
  const MultiBeam beams(sphere, {});  // the offsets the distortion loops read
  const std::size_t n = sphere.vertex_count();
  const std::size_t padded = n + vertex_kernels::kPadding;
  const std::uint32_t stations = beams.stations();
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);

  // Random beams of a 1 mm press (metres and radians), continuous at the knots.
  constexpr std::uint32_t kBeams = 3;
  std::vector<std::vector<float>> coefficients(kBeams, std::vector<float>(stations * vertex_kernels::kCoefficients));
  for (auto& beam : coefficients) {
    for (std::uint32_t e = 0; e < stations; ++e) {
      float* c = beam.data() + e * vertex_kernels::kCoefficients;
      for (std::uint32_t k = 0; k < vertex_kernels::kPolynomialCoefficients; ++k)
        c[k] = static_cast<float>(1e-3 * unit(random));
      if (e == 0) continue;
      const float* previous = c - vertex_kernels::kCoefficients;
      for (int k = 0; k < 3; ++k) {
        c[k] = previous[k] + previous[3 + k] + previous[6 + k] + previous[9 + k];
        c[12 + k] = previous[12 + k] + previous[15 + k];
      }
    }
    vertex_kernels::add_knot_terms(beam.data(), stations);
  }
  const double group_points[kBeams][3] = {{0.08, 0.0, 0.0}, {0.0, 0.0, 0.08}, {0.0, 0.08, 0.0}};
  // L⁻¹ for the three points (column-major, stride 3), as the influence function holds it.
  Eigen::Matrix3d distances;
  for (std::uint32_t i = 0; i < kBeams; ++i)
    for (std::uint32_t j = 0; j < kBeams; ++j)
      distances(i, j) = (Eigen::Vector3d(group_points[i]) - Eigen::Vector3d(group_points[j])).norm();
  const Eigen::Matrix3d inverse = distances.inverse();

  const vertex_kernels::RunnableSets sets = vertex_kernels::runnable();
  std::vector<std::vector<double>> weights_of(sets.count), positions_of(sets.count), normals_of(sets.count),
      packed_normals_of(sets.count);
  for (std::size_t s = 0; s < sets.count; ++s) {
    const vertex_kernels::KernelSet& set = sets.set[s];
    SCOPED_TRACE(set.level);
    std::vector<std::vector<float>> weights(kBeams, std::vector<float>(padded, 0.0f));
    vertex_kernels::WeightJob weight_job{};
    weight_job.rest[0] = sphere.rest_x();
    weight_job.rest[1] = sphere.rest_y();
    weight_job.rest[2] = sphere.rest_z();
    weight_job.attenuation_rate = 20.0;
    weight_job.groups = kBeams;
    weight_job.group_points = group_points[0];
    weight_job.inverse = inverse.data();
    weight_job.inverse_stride = 3;
    weight_job.beams = kBeams;
    weight_job.offset[0] = beams.offset_x();
    weight_job.offset[1] = beams.offset_y();
    weight_job.offset[2] = beams.offset_z();
    weight_job.stations = stations;
    weight_job.vertex_count = n;
    std::vector<std::vector<std::uint16_t>> chunk_elements(kBeams,
                                                           std::vector<std::uint16_t>(padded / vertex_kernels::kChunk));
    vertex_kernels::BeamAxis axes[kBeams];
    for (std::uint32_t b = 0; b < kBeams; ++b) {
      const Eigen::Vector3f axis =
          Eigen::Vector3f(static_cast<float>(-group_points[b][0]), 0.3f, static_cast<float>(group_points[b][2]))
              .normalized();
      constexpr float kLength = 0.09f;  // m
      axes[b] = {{axis[0] * stations / kLength, axis[1] * stations / kLength, axis[2] * stations / kLength},
                 {axis[0] * kLength / stations, axis[1] * kLength / stations, axis[2] * kLength / stations}};
      weight_job.beam[b] = {{group_points[b][0], group_points[b][1], group_points[b][2]},
                            1.0,
                            b,
                            axes[b],
                            weights[b].data(),
                            chunk_elements[b].data()};
    }
    const std::size_t third =
        n / 3 / vertex_kernels::kChunk * vertex_kernels::kChunk;  // two ranges, as two threads would
    set.build_weights(weight_job, 0, third);
    set.build_weights(weight_job, third, n);

    std::vector<model::Point3> positions(n), normals(n);
    vertex_kernels::DistortionJob job{};
    job.offset[0] = beams.offset_x();
    job.offset[1] = beams.offset_y();
    job.offset[2] = beams.offset_z();
    job.rest[0] = sphere.rest_x();
    job.rest[1] = sphere.rest_y();
    job.rest[2] = sphere.rest_z();
    job.stations = stations;
    job.beams = kBeams;
    for (std::uint32_t b = 0; b < kBeams; ++b)
      job.beam[b] = {axes[b], weights[b].data(), chunk_elements[b].data(), coefficients[b].data()};
    job.positions = positions[0].data();
    std::vector<float> packed(4 * padded);
    job.packed = packed.data();
    const std::size_t half =
        n / 2 / vertex_kernels::kPadding * vertex_kernels::kPadding;  // two ranges, as two threads would
    set.distort(job, 0, half);
    set.distort(job, half, n);

    // On the same positions for every level (each level's distortion rounds differently).
    vertex_kernels::NormalsJob normals_job{sphere.ring_row_offsets().data(), sphere.ring_rows().data(), n,
                                           sphere.model().surface_vertices[0].data(), normals[0].data()};
    set.normals(normals_job, 0, n);
    // The packed points distort() wrote: its positions relative to the fixed point, in single precision.
    for (std::size_t v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(packed[4 * v + k], positions[v][k] - sphere.fixed_point()[k], 1e-8) << v;
    // Packed normals of the rest shape (the same points for every level), in two ranges.
    std::vector<float> rest_packed(4 * padded, 0.0f);
    for (std::size_t v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) rest_packed[4 * v + k] = static_cast<float>(sphere.model().surface_vertices[v][k]);
    std::vector<model::Point3> from_packed(n);
    vertex_kernels::PackedNormalsJob packed_job{sphere.ring_row_offsets().data(), sphere.ring_rows().data(),
                                                rest_packed.data(), from_packed[0].data()};
    set.packed_normals(packed_job, 0, n / 3);
    set.packed_normals(packed_job, n / 3, n);
    for (std::size_t v = 0; v < n; ++v) {
      ASSERT_NEAR(Eigen::Vector3d(from_packed[v].data()).norm(), 1.0, 1e-6) << v;
      ASSERT_LT((Eigen::Vector3d(from_packed[v].data()) - Eigen::Vector3d(normals[v].data())).norm(), 1e-5) << v;
    }
    packed_normals_of[s].assign(from_packed[0].data(), from_packed[0].data() + 3 * n);

    for (const auto& beam : weights) weights_of[s].insert(weights_of[s].end(), beam.begin(), beam.begin() + n);
    positions_of[s].assign(positions[0].data(), positions[0].data() + 3 * n);
    normals_of[s].assign(normals[0].data(), normals[0].data() + 3 * n);

    // The distortion is each beam's polynomials of the element each vertex lies
    // in (evaluated here in double, one vertex at a time), weighted.
    double worst = 0.0;
    for (std::size_t v = 0; v < n; ++v) {
      const Eigen::Vector3d p(beams.offset_x()[v], beams.offset_y()[v], beams.offset_z()[v]);
      Eigen::Vector3d expected = Eigen::Vector3d::Zero();
      for (std::uint32_t b = 0; b < kBeams; ++b) {
        const Eigen::Vector3d to_elements(axes[b].to_elements[0], axes[b].to_elements[1], axes[b].to_elements[2]);
        const Eigen::Vector3d step(axes[b].element_step[0], axes[b].element_step[1], axes[b].element_step[2]);
        const double tau = std::clamp(p.dot(to_elements), 0.0, static_cast<double>(stations));
        const std::uint32_t element = std::min(static_cast<std::uint32_t>(tau), stations - 1);
        const double xi = tau - element;
        const std::uint32_t entry = chunk_elements[b][v / vertex_kernels::kChunk];
        ASSERT_GE(element, entry % vertex_kernels::kMaxStations) << v;
        ASSERT_LE(element - entry % vertex_kernels::kMaxStations,
                  entry >> vertex_kernels::kElementBits == 2 ? stations : entry >> vertex_kernels::kElementBits)
            << v;
        const float* c = coefficients[b].data() + element * vertex_kernels::kCoefficients;
        Eigen::Vector3d u, theta;
        for (int k = 0; k < 3; ++k) {  // the records hold halves
          u[k] = 2.0 * (((c[9 + k] * xi + c[6 + k]) * xi + c[3 + k]) * xi + c[k]);
          theta[k] = 2.0 * (c[12 + k] + xi * c[15 + k]);
        }
        const Eigen::Vector3d q = p - tau * step;
        const Eigen::Vector3d rotated = theta.cross(q);
        expected += weights[b][v] * (u + rotated + 0.5 * theta.cross(rotated));
      }
      const Eigen::Vector3d moved =
          Eigen::Vector3d(positions[v].data()) - Eigen::Vector3d(sphere.model().surface_vertices[v].data());
      worst = std::max(worst, (moved - expected).norm());
    }
    EXPECT_LT(worst, 1e-8);  // m: float rounding of millimetre displacements (4·10⁻⁹ measured)

    // The kernels did work: weights in (0, 1] at the action points' side, vertices moved.
    double moved = 0.0;
    for (std::size_t v = 0; v < n; ++v)
      moved = std::max(
          moved,
          (Eigen::Vector3d(positions[v].data()) - Eigen::Vector3d(sphere.model().surface_vertices[v].data())).norm());
    EXPECT_GT(moved, 1e-4);
    for (std::size_t v = 0; v < n; ++v) ASSERT_NEAR(Eigen::Vector3d(normals[v].data()).norm(), 1.0, 1e-12) << v;
  }
  for (std::size_t s = 1; s < sets.count; ++s) {
    SCOPED_TRACE(std::string(sets.set[s].level) + " against " + sets.set[0].level);
    EXPECT_LT(largest_difference(weights_of[s], weights_of[0]), 1e-6);      // single-precision weights in [−1, 1]
    EXPECT_LT(largest_difference(positions_of[s], positions_of[0]), 1e-8);  // m: float rounding of mm displacements
    EXPECT_LT(largest_difference(normals_of[s], normals_of[0]), 1e-14);
    EXPECT_LT(largest_difference(packed_normals_of[s], packed_normals_of[0]), 1e-5);  // float, FMA or not
  }
}

}  // namespace
}  // namespace organsim::multibeam
