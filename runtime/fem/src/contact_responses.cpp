#include "organsim/fem/contact_responses.h"

#include <algorithm>
#include <vector>

namespace organsim::fem {
namespace {

/// Calls `term(unknown, direction, weight)` for each unit load of `load`.
template <typename Term>
void for_each_load(const PointLoad& load, Term term) noexcept {
  for (std::size_t i = 0; i < load.count; ++i) {
    const double weight = load.weights[i];
    if (weight == 0.0) continue;
    for (int k = 0; k < 3; ++k)
      if (load.dofs[i][static_cast<std::size_t>(k)] >= 0) term(load.dofs[i][static_cast<std::size_t>(k)], k, weight);
  }
}

/// A load kept for its slot: its arrays copied into storage of the largest size.
struct KeptLoad {
  std::vector<std::array<std::int32_t, 3>> dofs = std::vector<std::array<std::int32_t, 3>>(PointLoad::kMaxNodes);
  std::vector<double> weights = std::vector<double>(PointLoad::kMaxNodes, 0.0);
  std::size_t count = 0;

  void keep(const PointLoad& load) noexcept {
    count = std::min(load.count, PointLoad::kMaxNodes);
    std::copy(load.dofs, load.dofs + count, dofs.begin());
    std::copy(load.weights, load.weights + count, weights.begin());
  }
  PointLoad view() const noexcept { return {dofs.data(), weights.data(), count}; }
};

/// Responses solved in full (A⁻¹ e, three columns) with any factorization.
class FullResponses final : public ContactResponses {
 public:
  FullResponses(Factorization& factorization, Eigen::Index rows, std::size_t slots)
      : factorization_(factorization),
        responses_(slots, Eigen::MatrixX3d::Zero(rows, 3)),
        loads_(slots),
        unit_(Eigen::MatrixX3d::Zero(rows, 3)),
        step_(Eigen::VectorXd::Zero(rows)) {}

  void clear() noexcept override {}

  void respond(std::size_t slot, const PointLoad& load) noexcept override {
    for_each_load(load, [&](std::int32_t unknown, int k, double weight) { unit_(unknown, k) += weight; });
    factorization_.solve3(unit_, responses_[slot]);
    for_each_load(load, [&](std::int32_t unknown, int k, double) { unit_(unknown, k) = 0.0; });
    loads_[slot].keep(load);
  }

  Eigen::Matrix3d coupling(std::size_t s, std::size_t t) const noexcept override {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for_each_load(loads_[s].view(),
                  [&](std::int32_t unknown, int i, double weight) { m.row(i) += weight * responses_[t].row(unknown); });
    return m;
  }

  void begin_step(const Eigen::Ref<const Eigen::VectorXd>& r) noexcept override { factorization_.solve(r, step_); }

  Eigen::Vector3d projected(std::size_t s) const noexcept override {
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for_each_load(loads_[s].view(),
                  [&](std::int32_t unknown, int i, double weight) { v[i] += weight * step_[unknown]; });
    return v;
  }

  void add(std::size_t s, const Eigen::Vector3d& c) noexcept override { step_.noalias() += responses_[s] * c; }

  void finish_step(Eigen::Ref<Eigen::VectorXd> step) noexcept override { step = step_; }

 private:
  Factorization& factorization_;
  std::vector<Eigen::MatrixX3d> responses_;  ///< per slot: A⁻¹ e, rows × 3
  std::vector<KeptLoad> loads_;
  Eigen::MatrixX3d unit_;  ///< the loads of the response being solved (zero between solves)
  Eigen::VectorXd step_;
};

/// Responses kept as forward halves z = L⁻¹ P e on their supernodes.
template <typename Scalar>
class SupernodalResponses final : public ContactResponses {
 public:
  SupernodalResponses(const SupernodalFactor& factor, const SupernodalView<Scalar>& l, std::size_t slots)
      : factor_(factor),
        l_(l),
        supernode_of_row_(static_cast<std::size_t>(factor.rows)),
        marked_(l.supernodes, 0),
        slots_(slots),
        couplings_(slots * slots, Eigen::Matrix3d::Zero()),
        y_(Eigen::MatrixX3d::Zero(factor.rows, 3)),
        below_(Eigen::MatrixX3d::Zero(std::max<Eigen::Index>(l.most_rows_below(), 1), 3)) {
    for (std::size_t s = 0; s < l.supernodes; ++s)
      for (int row = l.first[s]; row < l.first[s + 1]; ++row)
        supernode_of_row_[static_cast<std::size_t>(row)] = static_cast<int>(s);
    for (Slot& slot : slots_) {
      slot.z = Eigen::MatrixX3d::Zero(factor.rows, 3);
      slot.support.reserve(l.supernodes);
    }
  }

  void clear() noexcept override {
    for (Slot& slot : slots_) slot.valid = false;
  }

  void respond(std::size_t index, const PointLoad& load) noexcept override {
    Slot& slot = slots_[index];
    for (int s : slot.support) slot.z.middleRows(l_.first[s], l_.columns(static_cast<std::size_t>(s))).setZero();
    slot.support.clear();
    // The support: the loaded rows' supernodes and, closed upward, those
    // their rows below the diagonal fall in (their ancestors), ascending.
    std::size_t lowest = l_.supernodes;
    for_each_load(load, [&](std::int32_t unknown, int k, double weight) {
      const int row = factor_.order[unknown];
      slot.z(row, k) += weight;
      const auto s = static_cast<std::size_t>(supernode_of_row_[static_cast<std::size_t>(row)]);
      marked_[s] = 1;
      lowest = std::min(lowest, s);
    });
    for (std::size_t s = lowest; s < l_.supernodes; ++s) {
      if (!marked_[s]) continue;
      marked_[s] = 0;
      slot.support.push_back(static_cast<int>(s));
      const int* rows = l_.row_index + l_.rows[s];
      for (Eigen::Index i = l_.columns(s); i < l_.height(s); ++i)
        marked_[static_cast<std::size_t>(supernode_of_row_[static_cast<std::size_t>(rows[i])])] = 1;
    }
    double* y[3] = {slot.z.col(0).data(), slot.z.col(1).data(), slot.z.col(2).data()};
    double* t[3] = {below_.col(0).data(), below_.col(1).data(), below_.col(2).data()};
    for (int s : slot.support) supernodal_forward_node<3>(l_, static_cast<std::size_t>(s), y, t);
    slot.valid = true;
    for (std::size_t other = 0; other < slots_.size(); ++other)
      if (slots_[other].valid) {
        const Eigen::Matrix3d m = scaled_product(slot, slots_[other]);
        couplings_[index * slots_.size() + other] = m;
        couplings_[other * slots_.size() + index] = m.transpose();
      }
  }

  Eigen::Matrix3d coupling(std::size_t s, std::size_t t) const noexcept override {
    return couplings_[s * slots_.size() + t];
  }

  void begin_step(const Eigen::Ref<const Eigen::VectorXd>& r) noexcept override {
    for (Eigen::Index i = 0; i < r.size(); ++i) y_(factor_.order[i], 0) = r[i];
    supernodal_forward_solve(l_, y_, below_);
  }

  Eigen::Vector3d projected(std::size_t index) const noexcept override {
    const Slot& slot = slots_[index];
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (int s : slot.support)
      for (int row = l_.first[s]; row < l_.first[s + 1]; ++row)
        v += slot.z.row(row).transpose() * (y_(row, 0) / pivot(row));
    return v;
  }

  void add(std::size_t index, const Eigen::Vector3d& c) noexcept override {
    const Slot& slot = slots_[index];
    for (int s : slot.support)
      for (int row = l_.first[s]; row < l_.first[s + 1]; ++row) y_(row, 0) += slot.z.row(row).dot(c);
  }

  void finish_step(Eigen::Ref<Eigen::VectorXd> step) noexcept override {
    supernodal_backward_solve(l_, factor_.pivots, y_, below_);
    for (Eigen::Index i = 0; i < step.size(); ++i) step[i] = y_(factor_.order[i], 0);
  }

 private:
  struct Slot {
    Eigen::MatrixX3d z;        ///< L⁻¹ P e, zero off the support
    std::vector<int> support;  ///< its supernodes, ascending
    bool valid = false;
  };

  double pivot(int row) const noexcept { return factor_.pivots ? factor_.pivots[row] : 1.0; }

  /// aᵀ D⁻¹ b over the supernodes the two supports share.
  Eigen::Matrix3d scaled_product(const Slot& a, const Slot& b) const noexcept {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    auto i = a.support.begin(), j = b.support.begin();
    while (i != a.support.end() && j != b.support.end()) {
      if (*i < *j) {
        ++i;
      } else if (*j < *i) {
        ++j;
      } else {
        for (int row = l_.first[*i]; row < l_.first[*i + 1]; ++row)
          m.noalias() += a.z.row(row).transpose() * (b.z.row(row) / pivot(row));
        ++i, ++j;
      }
    }
    return m;
  }

  const SupernodalFactor& factor_;
  const SupernodalView<Scalar>& l_;
  std::vector<int> supernode_of_row_;
  std::vector<unsigned char> marked_;  ///< scratch of respond(): zero between calls
  std::vector<Slot> slots_;
  std::vector<Eigen::Matrix3d> couplings_;  ///< slots × slots, row-major by slot
  Eigen::MatrixX3d y_;                      ///< the step's forward half (first column)
  Eigen::MatrixX3d below_;                  ///< the forward and backward passes' workspace
};

}  // namespace

std::unique_ptr<ContactResponses> ContactResponses::make(Factorization& factorization, Eigen::Index rows,
                                                         std::size_t slots) {
  if (const SupernodalFactor* factor = factorization.supernodal_factor()) {
    if (factor->single_values)
      return std::make_unique<SupernodalResponses<float>>(*factor, *factor->single_values, slots);
    if (factor->double_values)
      return std::make_unique<SupernodalResponses<double>>(*factor, *factor->double_values, slots);
  }
  return std::make_unique<FullResponses>(factorization, rows, slots);
}

}  // namespace organsim::fem
