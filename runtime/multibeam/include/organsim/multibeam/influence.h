// How the displacement fields of several beams are merged (Ushiki et al.,
// multi-beam paper, eqs. 5–8; docs/multibeam.md#references).
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/LU>

namespace organsim::multibeam {

/// The most tools one state handles; the per-vertex work keeps its scratch on
/// the stack, so the bound is a compile-time constant.
inline constexpr std::uint32_t kMaxTools = 16;

enum class MergeRule : std::uint8_t {
  influence,  ///< u'(p) = Σ f_i(p) u_i(p), f(p) = L⁻¹ l(p) / ‖L⁻¹ l(p)‖₁ (eq. 7); the default
  sum,        ///< u(p) = Σ u_i(p) (eq. 5): shows the paper's Fig. 5 artefact
};

/// The influence function f(p) = L⁻¹ l(p) / ‖L⁻¹ l(p)‖₁ of N distinct action
/// points p_1..p_N, where l(p) = [|p − p_1|, …, |p − p_N|]ᵀ and L = [l(p_1) … l(p_N)]ᵀ.
/// f(p_i) = e_i exactly; for N = 2, f(p) = [l₂, l₁] / (l₁ + l₂) (eq. 8); f is
/// continuous. The distance matrix of distinct points is invertible (Micchelli
/// 1986), but nearly coinciding points make it ill-conditioned: merge points
/// closer than a tolerance before calling set_points. Allocates nothing.
class InfluenceFunction {
 public:
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxTools, kMaxTools>;

  /// Returns false when count is 0 or above kMaxTools, a point is not finite,
  /// or the distance matrix is singular (coinciding points).
  bool set_points(const Eigen::Vector3d* points, std::uint32_t count) noexcept;

  std::uint32_t count() const noexcept { return count_; }
  const Eigen::Vector3d& point(std::uint32_t i) const noexcept { return points_[i]; }
  /// L⁻¹ (N × N); for N = 1 the 1×1 identity (the single weight is 1).
  const Matrix& inverse_distances() const noexcept { return inverse_; }

  /// Writes f_1..f_N for point p into `weights` (N entries).
  void weights(const Eigen::Vector3d& p, double* weights) const noexcept;

 private:
  std::uint32_t count_ = 0;
  Eigen::Vector3d points_[kMaxTools];
  Matrix inverse_;
};

/// Normalizes v to unit 1-norm in place (v / ‖v‖₁), the last step of eq. 7.
void normalize_influence(double* v, std::uint32_t count) noexcept;

}  // namespace organsim::multibeam
