#include "organsim/fem/supernodal_solve.h"

namespace organsim::fem {
namespace {

template <int K, typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void solve_columns(const SupernodalView<Scalar>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                          Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  supernodal_forward<K>(l, y, below);
  if (pivots)
    for (int c = 0; c < K; ++c)
      for (Eigen::Index i = 0; i < y.rows(); ++i) y(i, c) /= pivots[i];
  supernodal_backward<K>(l, y, below);
}

template <typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void solve_any(const SupernodalView<Scalar>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                      int columns, Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  if (columns == 3)
    solve_columns<3>(l, pivots, y, below);
  else
    solve_columns<1>(l, pivots, y, below);
}

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && !defined(__AVX2__)
// The same loops inlined into functions compiled for AVX2 and FMA.
#define ORGANSIM_SOLVE_LEVELS 1
__attribute__((target("arch=x86-64-v3"))) void solve_v3(const SupernodalView<double>& l, const double* pivots,
                                                          Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                                                          Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  solve_any(l, pivots, y, columns, below);
}
__attribute__((target("arch=x86-64-v3"))) void solve_v3(const SupernodalView<float>& l, const double* pivots,
                                                          Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                                                          Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  solve_any(l, pivots, y, columns, below);
}
const bool kHasV3 = [] {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}();
#endif

template <typename Scalar>
void dispatch(const SupernodalView<Scalar>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y, int columns,
              Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
#ifdef ORGANSIM_SOLVE_LEVELS
  if (kHasV3) return solve_v3(l, pivots, y, columns, below);
#endif
  solve_any(l, pivots, y, columns, below);
}

}  // namespace

void supernodal_solve(const SupernodalView<double>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                      int columns, Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, pivots, y, columns, below);
}

void supernodal_solve(const SupernodalView<float>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                      int columns, Eigen::Ref<Eigen::MatrixX3d> below) noexcept {
  dispatch(l, pivots, y, columns, below);
}

}  // namespace organsim::fem
