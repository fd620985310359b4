// Triangular solves with a supernodal factor, in our own loops: a pass over
// dense column blocks that allocates nothing, takes no lock and solves up to
// three right-hand sides (a contact's three directions) in one pass over the
// factor, whose memory traffic is what a solve costs.
//
// A supernode is a run of columns of L with one row structure below their
// diagonal block: it is stored as one dense column-major block, so that the
// solve reads it as streams (the FEM factors' supernodes of 3 columns and
// more — a node's three displacements at least — make most of the factor
// dense blocks). CHOLMOD's supernodal factor is laid out this way
// (direct_factorizations.h); the simplicial factorization copies its LDLᵀ
// factor into the same layout (factorization.cpp), in double or single
// precision.
#pragma once

#include <algorithm>
#include <cstddef>

#include <Eigen/Core>

// Inlined into every caller, so that the copies compiled for AVX2
// (supernodal_solve.cpp) are AVX2 code throughout.
#if defined(__GNUC__)
#define ORGANSIM_SUPERNODAL_INLINE inline __attribute__((always_inline))
#else
#define ORGANSIM_SUPERNODAL_INLINE inline
#endif

namespace organsim::fem {

/// A supernodal lower triangular factor L (CHOLMOD's layout, referred to, not
/// owned). Supernode s holds the columns first[s] … first[s + 1] − 1 as a
/// dense column-major block of rows[s + 1] − rows[s] rows starting at
/// values + value_start[s]; the block's first rows are those columns' own (its
/// diagonal triangle, the diagonal included, read below the diagonal only)
/// and row_index + rows[s] lists every row of the block in L's row numbering.
/// Values in double or single precision (the solves add up in double).
template <typename Scalar>
struct SupernodalView {
  std::size_t supernodes = 0;
  const int* first = nullptr;
  const int* rows = nullptr;
  const int* value_start = nullptr;
  const int* row_index = nullptr;
  const Scalar* values = nullptr;

  Eigen::Index columns(std::size_t s) const noexcept { return first[s + 1] - first[s]; }
  Eigen::Index height(std::size_t s) const noexcept { return rows[s + 1] - rows[s]; }
  /// The most rows below a supernode's diagonal block: the solves' workspace.
  Eigen::Index most_rows_below() const noexcept {
    Eigen::Index most = 0;
    for (std::size_t s = 0; s < supernodes; ++s) most = std::max(most, height(s) - columns(s));
    return most;
  }
};

namespace detail {
/// out[c] = Σ a_i b[c]_i for the K columns b[c], reading a once, in a fixed
/// order: eight partial sums per column (lanes the compiler vectorizes
/// without reassociating), then the rest, then the lanes.
template <int K, typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void dots(const Scalar* a, double* const* b, Eigen::Index count, double* out) noexcept {
  constexpr Eigen::Index kLanes = 8;
  double lane[K][kLanes] = {};
  Eigen::Index i = 0;
  for (; i + kLanes <= count; i += kLanes)
    for (Eigen::Index k = 0; k < kLanes; ++k) {
      const double value = static_cast<double>(a[i + k]);
      for (int c = 0; c < K; ++c) lane[c][k] += value * b[c][i + k];
    }
  for (int c = 0; c < K; ++c) {
    double sum = 0;
    for (Eigen::Index r = i; r < count; ++r) sum += static_cast<double>(a[r]) * b[c][r];
    for (Eigen::Index k = 0; k < kLanes; ++k) sum += lane[c][k];
    out[c] = sum;
  }
}
/// The first K columns of the right-hand sides and of the workspace.
template <int K>
ORGANSIM_SUPERNODAL_INLINE void column_pointers(Eigen::Ref<Eigen::MatrixX3d>& y_columns,
                                                Eigen::Ref<Eigen::MatrixX3d>& below_columns, double** y,
                                                double** t) noexcept {
  for (int c = 0; c < K; ++c) y[c] = y_columns.col(c).data(), t[c] = below_columns.col(c).data();
}
}  // namespace detail

/// Supernode s's part of Y = L⁻¹ Y (supernodal_forward, in ascending order):
/// its diagonal triangle, then its rows below as L₂₁ Y₁ gathered in the
/// workspace `t` and subtracted where they belong (rows of the supernode's
/// ancestors in the elimination tree).
template <int K, typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void supernodal_forward_node(const SupernodalView<Scalar>& l, std::size_t s,
                                                        double* const* y, double* const* t) noexcept {
  const Eigen::Index n = l.columns(s), height = l.height(s), below = height - n, first = l.first[s];
  const Scalar* values = l.values + l.value_start[s];
  for (Eigen::Index j = 0; j < n; ++j) {
    const Scalar* column = values + j * height;
    for (int c = 0; c < K; ++c) {
      double* yc = y[c] + first;
      const double pivot = yc[j] /= column[j];
      for (Eigen::Index i = j + 1; i < n; ++i) yc[i] -= column[i] * pivot;
    }
  }
  if (below == 0) return;
  for (int c = 0; c < K; ++c) std::fill(t[c], t[c] + below, 0.0);
  Eigen::Index j = 0;
  for (; j + 4 <= n; j += 4) {  // four columns per sweep: a quarter of the passes over t
    const Scalar* l0 = values + j * height + n;
    const Scalar* l1 = l0 + height;
    const Scalar* l2 = l1 + height;
    const Scalar* l3 = l2 + height;
    double yj[K][4];
    for (int c = 0; c < K; ++c)
      for (int q = 0; q < 4; ++q) yj[c][q] = y[c][first + j + q];
    for (Eigen::Index i = 0; i < below; ++i) {  // each value read once for the K columns
      const double a0 = l0[i], a1 = l1[i], a2 = l2[i], a3 = l3[i];
      for (int c = 0; c < K; ++c) t[c][i] += (a0 * yj[c][0] + a1 * yj[c][1]) + (a2 * yj[c][2] + a3 * yj[c][3]);
    }
  }
  for (; j < n; ++j) {
    const Scalar* l0 = values + j * height + n;
    for (int c = 0; c < K; ++c) {
      const double y0 = y[c][first + j];
      double* tc = t[c];
      for (Eigen::Index i = 0; i < below; ++i) tc[i] += l0[i] * y0;
    }
  }
  const int* rows = l.row_index + l.rows[s] + n;
  for (int c = 0; c < K; ++c)
    for (Eigen::Index i = 0; i < below; ++i) y[c][rows[i]] -= t[c][i];
}

/// Y = L⁻¹ Y for the first K columns of `y` (L's row order), in place;
/// `below` holds at least most_rows_below() rows and K columns.
template <int K, typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void supernodal_forward(const SupernodalView<Scalar>& l,
                                                   Eigen::Ref<Eigen::MatrixX3d> y_columns,
                                                   Eigen::Ref<Eigen::MatrixX3d> below_columns) noexcept {
  double* y[K];
  double* t[K];
  detail::column_pointers<K>(y_columns, below_columns, y, t);
  for (std::size_t s = 0; s < l.supernodes; ++s) supernodal_forward_node<K>(l, s, y, t);
}

/// Y = L⁻ᵀ Y for the first K columns of `y`, in place (workspace as above).
template <int K, typename Scalar>
ORGANSIM_SUPERNODAL_INLINE void supernodal_backward(const SupernodalView<Scalar>& l,
                                                    Eigen::Ref<Eigen::MatrixX3d> y_columns,
                                                    Eigen::Ref<Eigen::MatrixX3d> below_columns) noexcept {
  double* y[K];
  double* t[K];
  detail::column_pointers<K>(y_columns, below_columns, y, t);
  // Supernodes in reverse: the rows below (solved already) gathered in t,
  // Y₁ −= L₂₁ᵀ t (four columns per sweep over t), then the diagonal
  // triangle transposed.
  for (std::size_t s = l.supernodes; s-- > 0;) {
    const Eigen::Index n = l.columns(s), height = l.height(s), below = height - n, first = l.first[s];
    const Scalar* values = l.values + l.value_start[s];
    const int* rows = l.row_index + l.rows[s] + n;
    for (int c = 0; c < K; ++c) {
      double* tc = t[c];
      for (Eigen::Index i = 0; i < below; ++i) tc[i] = y[c][rows[i]];
    }
    if (below > 0) {
      Eigen::Index j = 0;
      for (; j + 4 <= n; j += 4) {
        const Scalar* l0 = values + j * height + n;
        const Scalar* l1 = l0 + height;
        const Scalar* l2 = l1 + height;
        const Scalar* l3 = l2 + height;
        const Scalar* columns[4] = {l0, l1, l2, l3};
        for (int q = 0; q < 4; ++q) {
          double sums[K];
          detail::dots<K>(columns[q], t, below, sums);
          for (int c = 0; c < K; ++c) y[c][first + j + q] -= sums[c];
        }
      }
      for (; j < n; ++j) {
        double sums[K];
        detail::dots<K>(values + j * height + n, t, below, sums);
        for (int c = 0; c < K; ++c) y[c][first + j] -= sums[c];
      }
    }
    for (Eigen::Index j = n; j-- > 0;) {
      const Scalar* column = values + j * height;
      double* after[K];
      for (int c = 0; c < K; ++c) after[c] = y[c] + first + j + 1;
      double sums[K];
      detail::dots<K>(column + j + 1, after, n - j - 1, sums);
      for (int c = 0; c < K; ++c) y[c][first + j] = (y[c][first + j] - sums[c]) / static_cast<double>(column[j]);
    }
  }
}

/// Y = (L D Lᵀ)⁻¹ Y for the first `columns` (1 or 3) columns of `y`, in
/// place; `pivots` is D (null: L Lᵀ, L's own diagonal). The loops above,
/// compiled for the widest instruction set the CPU runs (AVX2 and FMA, or the
/// baseline; PSH's double-precision solve on the liver: 17.7 ms in the
/// portable build's SSE2 code, 14.1 ms with AVX2).
void supernodal_solve(const SupernodalView<double>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                      int columns, Eigen::Ref<Eigen::MatrixX3d> below) noexcept;
void supernodal_solve(const SupernodalView<float>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y, int columns,
                      Eigen::Ref<Eigen::MatrixX3d> below) noexcept;

/// The solve's two halves for the first column of `y`, in place: y = L⁻¹ y,
/// and y = L⁻ᵀ D⁻¹ y (`pivots` D, or null for L Lᵀ). A solve in parts
/// (supernodal_responses.h) changes y between them.
void supernodal_forward_solve(const SupernodalView<double>& l, Eigen::Ref<Eigen::MatrixX3d> y,
                              Eigen::Ref<Eigen::MatrixX3d> below) noexcept;
void supernodal_forward_solve(const SupernodalView<float>& l, Eigen::Ref<Eigen::MatrixX3d> y,
                              Eigen::Ref<Eigen::MatrixX3d> below) noexcept;
void supernodal_backward_solve(const SupernodalView<double>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                               Eigen::Ref<Eigen::MatrixX3d> below) noexcept;
void supernodal_backward_solve(const SupernodalView<float>& l, const double* pivots, Eigen::Ref<Eigen::MatrixX3d> y,
                               Eigen::Ref<Eigen::MatrixX3d> below) noexcept;

}  // namespace organsim::fem
