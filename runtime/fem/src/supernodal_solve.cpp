#include "organsim/fem/supernodal_solve.h"

namespace organsim::fem {
namespace {

enum class Part { whole, forward, backward };

template <int K, typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void solve_columns(const SupernodalView<Scalar>& l, const double* pivots,
                                              Eigen::Ref<Eigen::MatrixX3d> y, Eigen::Ref<Eigen::MatrixX3d> below,
                                              Part part) noexcept {
  if (part != Part::backward) supernodal_forward<K>(l, y, below);
  if (part == Part::forward) return;
  if (pivots)
    for (int c = 0; c < K; ++c)
      for (Eigen::Index i = 0; i < y.rows(); ++i) y(i, c) /= pivots[i];
  supernodal_backward<K>(l, y, below);
}

template <typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void solve_any(const SupernodalView<Scalar>& l, const double* pivots,
                                          Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                                          Eigen::Ref<Eigen::MatrixX3d> below, Part part) noexcept {
  if (columns == 3)
    solve_columns<3>(l, pivots, y, below, part);
  else
    solve_columns<1>(l, pivots, y, below, part);
}

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && !defined(__AVX2__)
// The same loops inlined into functions compiled for AVX2 and FMA.
#define ORGANSIM_SOLVE_LEVELS 1
__attribute__((target("arch=x86-64-v3"))) void solve_v3(const SupernodalView<double>& l, const double* pivots,
                                                        Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                                                        Eigen::Ref<Eigen::MatrixX3d> below, Part part) noexcept {
  solve_any(l, pivots, y, columns, below, part);
}
__attribute__((target("arch=x86-64-v3"))) void solve_v3(const SupernodalView<float>& l, const double* pivots,
                                                        Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                                                        Eigen::Ref<Eigen::MatrixX3d> below, Part part) noexcept {
  solve_any(l, pivots, y, columns, below, part);
}
const bool kHasV3 = [] {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}();
#endif

template <typename Scalar>
void dispatch(const SupernodalView<Scalar>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y, int columns,
              Eigen::Ref<Eigen::MatrixX3d> below, Part part) noexcept {
#ifdef ORGANSIM_SOLVE_LEVELS
  if (kHasV3) return solve_v3(l, pivots, y, columns, below, part);
#endif
  solve_any(l, pivots, y, columns, below, part);
}

}  // namespace

void supernodal_solve(const SupernodalView<double>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                      int columns, Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, pivots, y, columns, below, Part::whole);
}

void supernodal_solve(const SupernodalView<float>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                      Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, pivots, y, columns, below, Part::whole);
}

void supernodal_forward_solve(const SupernodalView<double>& l, Eigen::Ref<Eigen::MatrixX3d> y,
                              Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, nullptr, y, 1, below, Part::forward);
}

void supernodal_forward_solve(const SupernodalView<float>& l, Eigen::Ref<Eigen::MatrixX3d> y,
                              Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, nullptr, y, 1, below, Part::forward);
}

void supernodal_backward_solve(const SupernodalView<double>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                               Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, pivots, y, 1, below, Part::backward);
}

void supernodal_backward_solve(const SupernodalView<float>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                               Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, pivots, y, 1, below, Part::backward);
}

}  // namespace organsim::fem
