// The responses of a factorized tangent A to unit loads at a few points (a
// FEM contact's held points), and a step's solve that adds them: what the
// real-time frames' capacitance matrix W = Hᵀ A⁻¹ H and their step
// Δ = A⁻¹ (r + H λ) are made of (organ_fem.h).
//
// Where the factorization holds P A Pᵀ = L D Lᵀ in supernodes
// (Factorization::supernodal_factor), a load's response is kept as its forward
// half z = L⁻¹ P e. It is nonzero only on the supernodes on the elimination
// tree's paths from the loaded rows to the root, and a sparse forward solve
// (Gilbert and Peierls) visits only those: on the shipped liver a fraction of
// the factor, where a full three-column solve reads all of it twice. Then
// eₛᵀ A⁻¹ eₜ = zₛᵀ D⁻¹ zₜ over the two paths' common supernodes,
// eₛᵀ A⁻¹ r = zₛᵀ D⁻¹ y with y = L⁻¹ P r (the forward half of the step's
// solve), and the step is the backward half of y + Σ zₛ cₛ: a frame still costs
// one solve, and a new contact point a sparse forward solve instead of a solve
// of three columns. Otherwise (a factorization whose factor is not ours to
// read) each response is solved in full, A⁻¹ e, three columns.
//
// Construction allocates; every other call allocates nothing, takes no lock
// and does no I/O. Units are the tangent's (m/N for displacement rows).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "organsim/fem/factorization.h"

namespace organsim::fem {

/// Unit loads spread over a few nodes (a material point of a boundary face:
/// its barycentric weights; or a grasped patch: its area weights): weight
/// `weights[i]` on node i's three free unknowns `dofs[i]` (-1 for a clamped
/// one), one load per direction. The arrays are the caller's.
struct PointLoad {
  /// Most nodes a load spreads over.
  static constexpr std::size_t kMaxNodes = 256;
  const std::array<std::int32_t, 3>* dofs = nullptr;
  const double* weights = nullptr;
  std::size_t count = 0;
};

class ContactResponses {
 public:
  /// Responses in `slots` slots for `factorization`, factorized already (its
  /// supernodal factor, when it has one, is read from then on: every later
  /// factorization must keep its pattern). Allocates.
  static std::unique_ptr<ContactResponses> make(Factorization& factorization, Eigen::Index rows, std::size_t slots);
  virtual ~ContactResponses() = default;

  /// Forgets every response (the factorization changed).
  virtual void clear() noexcept = 0;
  /// Solves the response to `load` into `slot`, and its couplings with every
  /// slot that holds a response.
  virtual void respond(std::size_t slot, const PointLoad& load) noexcept = 0;
  /// eₛᵀ A⁻¹ eₜ (entry (i, k): slot s's point moved along i by slot t's unit
  /// load along k), for two slots that hold responses.
  virtual Eigen::Matrix3d coupling(std::size_t s, std::size_t t) const noexcept = 0;

  /// Starts a step's solve of A⁻¹ r (`r` over the free unknowns).
  virtual void begin_step(const Eigen::Ref<const Eigen::VectorXd>& r) noexcept = 0;
  /// eₛᵀ A⁻¹ r of the step begun: how slot s's point moves under r.
  virtual Eigen::Vector3d projected(std::size_t s) const noexcept = 0;
  /// Adds slot s's loads times `c` to the step's right-hand side.
  virtual void add(std::size_t s, const Eigen::Vector3d& c) noexcept = 0;
  /// The step: A⁻¹ (r + Σ eₛ cₛ).
  virtual void finish_step(Eigen::Ref<Eigen::VectorXd> step) noexcept = 0;
};

}  // namespace organsim::fem
