#include "organsim/pipeline/site_compliance.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SparseCholesky>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/material.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/geometry/tetrahedral_embedding.h"
#include "organsim/organ/site_law.h"
#ifdef ORGANSIM_HAVE_FEM_DIRECT
#include "organsim/fem_direct/direct_factorizations.h"
#endif

namespace organsim::pipeline {
namespace {

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

constexpr double kDefaultCurvatureRadius = 0.005;  // m: twice the default tip's radius

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Points bucketed in cubes of a given size, for the neighbours within a
/// few cubes of a place.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector3d>& points, double cell) : points_(points), cell_(cell) {
    for (std::size_t i = 0; i < points.size(); ++i)
      cells_[key(cell_of(points[i]))].push_back(static_cast<std::uint32_t>(i));
  }
  /// Indices of the points within `radius` of `at`, in increasing order.
  std::vector<std::uint32_t> within(const Eigen::Vector3d& at, double radius) const {
    std::vector<std::uint32_t> found;
    const Eigen::Vector3i c = cell_of(at);
    const int reach = static_cast<int>(std::ceil(radius / cell_));
    for (int i = -reach; i <= reach; ++i)
      for (int j = -reach; j <= reach; ++j)
        for (int k = -reach; k <= reach; ++k) {
          const auto it = cells_.find(key(c + Eigen::Vector3i(i, j, k)));
          if (it == cells_.end()) continue;
          for (std::uint32_t p : it->second)
            if ((points_[p] - at).norm() <= radius) found.push_back(p);
        }
    std::sort(found.begin(), found.end());
    return found;
  }

 private:
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const { return (p / cell_).array().floor().cast<int>(); }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    return (static_cast<std::uint64_t>(c[0] + (1 << 20)) << 42) | (static_cast<std::uint64_t>(c[1] + (1 << 20)) << 21) |
           static_cast<std::uint64_t>(c[2] + (1 << 20));
  }
  const std::vector<Eigen::Vector3d>& points_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

/// The factor's fill-reducing ordering: CHOLMOD's (the better of METIS and
/// AMD) where the direct library is built, else Eigen's AMD. On the shipped
/// liver METIS fills less (5.0 M factor entries against AMD's 6.7 M).
#ifdef ORGANSIM_HAVE_FEM_DIRECT
struct FillReducingOrdering {
  /// Eigen's convention: the inverse of the permutation P of P A Pᵀ.
  void operator()(const fem::SparseMatrix& full,
                  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>& inverse) const {
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation;
    fem::cholmod_ordering(full, permutation.indices());
    inverse = permutation.inverse();
  }
};
#else
using FillReducingOrdering = Eigen::AMDOrdering<int>;
#endif
using LdltFactor = Eigen::SimplicialLDLT<fem::SparseMatrix, Eigen::Lower, FillReducingOrdering>;

/// The factor's columns as solve_in_place reads them: L in compressed
/// columns (its unit diagonal stored too, and skipped), D⁻¹.
struct Factor {
  const int* outer;
  const int* inner;
  const double* value;
  const double* inverse_diagonal;
};
constexpr int kSolveBlock = 24;

// Cloned only where the build itself is below AVX2 (the portable x86-64
// build): a native build compiles the loops once, for its own CPU.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__)
#define ORGANSIM_SOLVE_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define ORGANSIM_SOLVE_CLONES
#endif

/// The marked part of L D Lᵀ y = y, in place, for a block of kSolveBlock
/// right-hand sides side by side (row-major): forward over the columns
/// marked `forward`, D⁻¹, backward over those marked `backward`. Plain loops
/// over a row's kSolveBlock values, which the compiler vectorizes; in the
/// portable build cloned for AVX2, chosen at load time where the CPU has it.
/// Without FMA (a separate instruction set, not enabled for the clone) each
/// value gets the same multiply and subtract, rounded the same, on both
/// clones: a portable build's results have the same bits on every CPU.
ORGANSIM_SOLVE_CLONES void solve_in_place(const Factor& l, int n, const char* forward, const char* backward,
                                          double* y) {
  for (int j = 0; j < n; ++j) {  // L z = P x, column by column
    if (!forward[j]) continue;
    double zj[kSolveBlock];
    std::copy(y + std::ptrdiff_t{kSolveBlock} * j, y + std::ptrdiff_t{kSolveBlock} * (j + 1), zj);
    for (int p = l.outer[j]; p < l.outer[j + 1]; ++p) {
      if (l.inner[p] <= j) continue;
      double* row = y + std::ptrdiff_t{kSolveBlock} * l.inner[p];
      const double v = l.value[p];
      for (int c = 0; c < kSolveBlock; ++c) row[c] -= v * zj[c];
    }
  }
  for (int j = 0; j < n; ++j) {
    if (!backward[j]) continue;
    double* row = y + std::ptrdiff_t{kSolveBlock} * j;
    if (forward[j])
      for (int c = 0; c < kSolveBlock; ++c) row[c] *= l.inverse_diagonal[j];
    else
      std::fill(row, row + kSolveBlock, 0.0);  // off the loads' paths: zero
  }
  for (int j = n - 1; j >= 0; --j) {  // Lᵀ w = D⁻¹ z, row by row of Lᵀ
    if (!backward[j]) continue;
    double wj[kSolveBlock];
    std::copy(y + std::ptrdiff_t{kSolveBlock} * j, y + std::ptrdiff_t{kSolveBlock} * (j + 1), wj);
    for (int p = l.outer[j]; p < l.outer[j + 1]; ++p) {
      if (l.inner[p] <= j) continue;
      const double* row = y + std::ptrdiff_t{kSolveBlock} * l.inner[p];
      const double v = l.value[p];
      for (int c = 0; c < kSolveBlock; ++c) wj[c] -= v * row[c];
    }
    std::copy(wj, wj + kSolveBlock, y + std::ptrdiff_t{kSolveBlock} * j);
  }
}

/// Solves with an LDLᵀ factor for a block of kBlock right-hand sides at once,
/// each row's kBlock values side by side: the factor, whose reading is what
/// a sparse triangular solve costs, is read once per block instead of once
/// per right-hand side. The right-hand sides are unit loads and only a few
/// rows of the solution are wanted (the boundary nodes near the loads), so
/// the solve reads only the columns of L that can matter (Gilbert and
/// Peierls): forward, those on the elimination-tree paths from the loaded
/// rows to the root (every other row of L⁻¹ P b is zero); backward, those on
/// the paths from the wanted rows (a row of Lᵀ w needs only rows below it,
/// its ancestors). Each column it reads gets the same operations in the same
/// order as in a dense solve, and the columns it skips would only have
/// subtracted zeros, so a wanted value has the same bits however its column
/// was blocked and whichever other rows were wanted with it.
class BlockSolver {
 public:
  static constexpr int kBlock = kSolveBlock;
  using Block = Eigen::Matrix<double, Eigen::Dynamic, kBlock, Eigen::RowMajor>;

  explicit BlockSolver(const LdltFactor& factor)
      : lower_(factor.matrixL().nestedExpression()),
        inverse_diagonal_(factor.vectorD().cwiseInverse()),
        permutation_(factor.permutationP()),
        parent_(static_cast<std::size_t>(lower_.cols()), -1) {
    // A column's parent in the elimination tree: its first row below the diagonal.
    const int* outer = lower_.outerIndexPtr();
    const int* inner = lower_.innerIndexPtr();
    for (Eigen::Index j = 0; j < lower_.cols(); ++j)
      for (int p = outer[j]; p < outer[j + 1]; ++p)
        if (inner[p] > j &&
            (parent_[static_cast<std::size_t>(j)] < 0 || inner[p] < parent_[static_cast<std::size_t>(j)]))
          parent_[static_cast<std::size_t>(j)] = inner[p];
  }

  /// Per-thread marks of the columns a solve reads.
  struct Workspace {
    Block y;
    std::vector<char> forward, backward;
  };
  Workspace workspace() const {
    const auto n = static_cast<std::size_t>(lower_.cols());
    return {Block(lower_.cols(), kBlock), std::vector<char>(n, 0), std::vector<char>(n, 0)};
  }

  /// Overwrites the `wanted` rows (the matrix's order) of `x` with those of
  /// A⁻¹ x, for an `x` that is zero outside the `loaded` rows; its other rows
  /// are left undefined.
  void solve(Block& x, const std::vector<int>& loaded, const std::vector<int>& wanted, Workspace& w) const {
    const Eigen::Index n = x.rows();
    const int* order = permutation_.indices().data();
    Block& y = w.y;
    mark_paths(loaded, order, w.forward);
    mark_paths(wanted, order, w.backward);
    for (Eigen::Index j = 0; j < n; ++j)
      if (w.forward[static_cast<std::size_t>(j)]) y.row(j).setZero();
    for (int i : loaded) y.row(order[i]) = x.row(i);
    const Factor factor{lower_.outerIndexPtr(), lower_.innerIndexPtr(), lower_.valuePtr(), inverse_diagonal_.data()};
    solve_in_place(factor, static_cast<int>(n), w.forward.data(), w.backward.data(), y.data());
    for (int i : wanted) x.row(i) = y.row(order[i]);
    std::fill(w.forward.begin(), w.forward.end(), 0);
    std::fill(w.backward.begin(), w.backward.end(), 0);
  }
  std::size_t factor_entries() const { return static_cast<std::size_t>(lower_.nonZeros()); }

 private:
  /// Marks the permuted rows of `rows` and their ancestors.
  void mark_paths(const std::vector<int>& rows, const int* order, std::vector<char>& marks) const {
    for (int i : rows)
      for (int j = order[i]; j >= 0 && !marks[static_cast<std::size_t>(j)]; j = parent_[static_cast<std::size_t>(j)])
        marks[static_cast<std::size_t>(j)] = 1;
  }

  const fem::SparseMatrix& lower_;
  Eigen::VectorXd inverse_diagonal_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  std::vector<int> parent_;  ///< per column of L: its parent, or −1 (a root)
};

/// Area-weighted outward unit normal of every surface vertex.
std::vector<Eigen::Vector3d> vertex_normals(const model::OrganModel& m) {
  std::vector<Eigen::Vector3d> normals(m.surface_vertices.size(), Eigen::Vector3d::Zero());
  for (const model::Triangle& t : m.surface_triangles) {
    const Eigen::Vector3d a = point(m.surface_vertices[t[0]]), b = point(m.surface_vertices[t[1]]),
                          c = point(m.surface_vertices[t[2]]);
    const Eigen::Vector3d twice_area_normal = (b - a).cross(c - a);
    for (std::uint32_t v : t) normals[v] += twice_area_normal;
  }
  for (Eigen::Vector3d& n : normals) n = n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::UnitZ();
  return normals;
}

/// A quadric z = a x² + b xy + c y² + d x + e y through `origin`, fitted by
/// least squares to `points` in the frame (t₁, t₂, n) there; its principal
/// curvatures at the origin, convex (curving away from n) positive, larger
/// first: the eigenvalues of −I⁻¹ II, I and II the graph's fundamental forms.
std::array<double, 2> fitted_curvatures(const Eigen::Vector3d& origin, const Eigen::Vector3d& normal,
                                        const std::vector<Eigen::Vector3d>& points) {
  const Eigen::Vector3d first = normal.unitOrthogonal(), second = normal.cross(first);
  Eigen::MatrixXd design(static_cast<Eigen::Index>(points.size()), 5);
  Eigen::VectorXd height(static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d d = points[i] - origin;
    const double x = d.dot(first), y = d.dot(second);
    design.row(static_cast<Eigen::Index>(i)) << x * x, x * y, y * y, x, y;
    height[static_cast<Eigen::Index>(i)] = d.dot(normal);
  }
  const Eigen::VectorXd q = design.colPivHouseholderQr().solve(height);
  const double slope_x = q[3], slope_y = q[4];
  Eigen::Matrix2d first_form, second_form;
  first_form << 1 + slope_x * slope_x, slope_x * slope_y, slope_x * slope_y, 1 + slope_y * slope_y;
  second_form << 2 * q[0], q[1], q[1], 2 * q[2];
  second_form /= std::sqrt(1 + slope_x * slope_x + slope_y * slope_y);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix2d> shape(-second_form, first_form,
                                                                        Eigen::EigenvaluesOnly);
  const auto clamped = [](double k) {
    return std::clamp(k, -model::SiteCompliance::kMaxCurvature, model::SiteCompliance::kMaxCurvature);
  };
  return {clamped(shape.eigenvalues()[1]), clamped(shape.eigenvalues()[0])};
}

std::array<double, 6> packed(const Eigen::Matrix3d& c) {
  return {c(0, 0), c(1, 1), c(2, 2), c(0, 1), c(0, 2), c(1, 2)};
}

/// The most rounds of releasing the contacts a press lifts: each round
/// releases those the last one left moving away from their support and
/// presses again those it moved into it; a press settles in a few.
constexpr int kReleaseRounds = 20;

/// Sites taken in runs of this many neighbours in the surface's (Morton)
/// order: a site's press mostly lifts the set its neighbour's did, which is
/// then checked rather than settled again.
constexpr std::size_t kSitesPerRun = 32;

/// The contacts a press lifts off their supports, and what releasing them
/// gives a site. The site compliances are computed with every contact's
/// spring K_c n_c n_cᵀ in the stiffness, as if each held both ways, and a
/// contact holds only while pressed. For a site, `toward` is each contact's
/// normal displacement (outward: into its support) per unit force on the
/// site's patch along x, y and z; `among` the contacts' normal compliance
/// among themselves; `springs` their K_c. With L a set of released contacts,
/// Woodbury's identity for the stiffness less their springs gives the patch
/// compliance C + h_Lᵀ (K_L⁻¹ − G_LL)⁻¹ h_L, and a press along −normal moves
/// the contacts by s' = −(toward + G_{·L} (K_L⁻¹ − G_LL)⁻¹ h_L) normal (the
/// matrix is positive definite: the clamp holds the organ without any
/// contact).
class ReleasedContacts {
 public:
  /// `inverse`: (K⁻¹ − G)⁻¹ over every contact, or empty. With it, a set
  /// that releases more contacts than it holds is solved through the held
  /// ones, (K_L⁻¹ − G_LL)⁻¹ = B_LL − B_LF B_FF⁻¹ B_FL with B the inverse and F
  /// the held set (the Schur complement): a dense factorization of the
  /// smaller of the two.
  ReleasedContacts(const Eigen::MatrixXd& among, const Eigen::VectorXd& springs, const Eigen::MatrixXd& inverse)
      : among_(among), springs_(springs), inverse_(inverse) {}

  /// Settles the set a press along −`normal` at the site of `toward` lifts,
  /// as a tensionless foundation's: released are the contacts that the
  /// press, with the set released, moves away from their support. Unless the
  /// set released now already holds, rounds start from those the two-way
  /// press lifts and go on until the set holds. The set a press settles on
  /// is unique, so where it starts changes nothing. False when the rounds
  /// ran out first (the last set is kept) or a set could not be factorized
  /// (nothing is released).
  bool settle(const Eigen::MatrixXd& toward, const Eigen::Vector3d& normal) {
    const Eigen::VectorXd pressed = -(toward * normal);
    if (factorized_ && lifted_by(toward, normal, pressed) == released_) return true;
    clear();
    std::vector<Eigen::Index> lifting;
    for (Eigen::Index c = 0; c < pressed.size(); ++c)
      if (pressed[c] < 0.0) lifting.push_back(c);
    for (int round = 0; round < kReleaseRounds; ++round) {
      released_.swap(lifting);
      if (released_.empty()) return true;
      if (!factorize()) return false;
      lifting = lifted_by(toward, normal, pressed);
      if (lifting == released_) return true;
    }
    return false;
  }

  /// Nothing released.
  void clear() {
    released_.clear();
    factorized_ = false;
  }

  /// m/N: what releasing the settled set adds to the compliance of the site
  /// of `toward`.
  Eigen::Matrix3d gained(const Eigen::MatrixXd& toward) const {
    if (!factorized_) return Eigen::Matrix3d::Zero();
    const Eigen::MatrixXd lifted = rows_of(toward);
    return lifted.transpose() * solve(lifted);
  }

 private:
  /// The contacts a press moves away from their support with the set
  /// released now (`pressed`: their displacement with none released).
  std::vector<Eigen::Index> lifted_by(const Eigen::MatrixXd& toward, const Eigen::Vector3d& normal,
                                      const Eigen::VectorXd& pressed) const {
    const Eigen::VectorXd through = solve(rows_of(toward)) * normal;
    Eigen::VectorXd moved = pressed;
    for (std::size_t i = 0; i < released_.size(); ++i)
      moved -= among_.col(released_[i]) * through[static_cast<Eigen::Index>(i)];
    std::vector<Eigen::Index> lifting;
    for (Eigen::Index c = 0; c < moved.size(); ++c)
      if (moved[c] < 0.0) lifting.push_back(c);
    return lifting;
  }
  Eigen::MatrixXd rows_of(const Eigen::MatrixXd& toward) const {
    Eigen::MatrixXd rows(static_cast<Eigen::Index>(released_.size()), 3);
    for (std::size_t i = 0; i < released_.size(); ++i)
      rows.row(static_cast<Eigen::Index>(i)) = toward.row(released_[i]);
    return rows;
  }
  /// (K_L⁻¹ − G_LL)⁻¹ `rows`.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rows) const {
    if (!through_held_) return factor_.solve(rows);
    return released_inverse_ * rows - across_.transpose() * factor_.solve(across_ * rows);
  }
  bool factorize() {
    const auto count = static_cast<Eigen::Index>(released_.size());
    const Eigen::Index contacts = among_.rows();
    through_held_ = inverse_.size() > 0 && 2 * count > contacts;
    if (!through_held_) {
      Eigen::MatrixXd system(count, count);
      for (Eigen::Index j = 0; j < count; ++j)  // column by column: `among` is column-major
        for (Eigen::Index i = 0; i < count; ++i) system(i, j) = -among_(released_[i], released_[j]);
      for (Eigen::Index i = 0; i < count; ++i) system(i, i) += 1.0 / springs_[released_[i]];
      factor_.compute(system);
    } else {
      std::vector<Eigen::Index> held;
      for (Eigen::Index c = 0, next = 0; c < contacts; ++c)
        if (next < count && released_[static_cast<std::size_t>(next)] == c)
          ++next;
        else
          held.push_back(c);
      const auto kept = static_cast<Eigen::Index>(held.size());
      released_inverse_.resize(count, count);
      across_.resize(kept, count);
      Eigen::MatrixXd held_inverse(kept, kept);
      for (Eigen::Index j = 0; j < count; ++j) {
        for (Eigen::Index i = 0; i < count; ++i) released_inverse_(i, j) = inverse_(released_[i], released_[j]);
        for (Eigen::Index i = 0; i < kept; ++i) across_(i, j) = inverse_(held[i], released_[j]);
      }
      for (Eigen::Index j = 0; j < kept; ++j)
        for (Eigen::Index i = 0; i < kept; ++i) held_inverse(i, j) = inverse_(held[i], held[j]);
      factor_.compute(held_inverse);
    }
    // Round-off at a contact that barely holds: nothing released.
    factorized_ = factor_.info() == Eigen::Success;
    return factorized_;
  }

  const Eigen::MatrixXd& among_;
  const Eigen::VectorXd& springs_;
  const Eigen::MatrixXd& inverse_;
  std::vector<Eigen::Index> released_;
  bool through_held_ = false;
  Eigen::MatrixXd released_inverse_, across_;  // B_LL, B_FL
  Eigen::LLT<Eigen::MatrixXd> factor_;         // of K_L⁻¹ − G_LL, or of B_FF through the held set
  bool factorized_ = false;
};

/// Per surface vertex of `model`, the organ's compliance under a tool there
/// (packed; model::SiteCompliance::compliance) for the stiffness `tangent` of
/// `system`'s free unknowns: one factorization, the boundary's Green's
/// function between nearby free boundary nodes, each site's patch mean less
/// the patch's own indentation. Adds its sizes and times to `report`.
std::vector<std::array<double, 6>> organ_compliances(const model::OrganModel& model,
                                                     const fem::ElasticitySystem& system,
                                                     const fem::SparseMatrix& tangent, const std::vector<bool>& clamped,
                                                     const std::vector<fem::FoundationSpring>& liftable,
                                                     const SiteComplianceOptions& o, SiteComplianceReport& report) {
  const fem::TetMesh& mesh = system.mesh();
  const auto factorization_start = std::chrono::steady_clock::now();
  // Quasi-definite: an LDLᵀ without pivoting exists for every symmetric ordering.
  const LdltFactor factor(tangent);
  if (factor.info() != Eigen::Success)
    throw std::invalid_argument(
        "the FEM stiffness at rest is singular: the clamp does not hold the organ (raise the clamp radius)");
  const double factorization_seconds = seconds_since(factorization_start);

  // The free boundary nodes, their lumped areas, and the patch radius.
  const geometry::TetrahedralBoundary boundary = geometry::tetrahedral_boundary(model.tetrahedra);
  std::vector<double> area(mesh.nodes.size(), 0.0);
  std::vector<double> edges;
  for (const model::Triangle& f : boundary.faces) {
    const Eigen::Vector3d a = mesh.nodes[f[0]], b = mesh.nodes[f[1]], c = mesh.nodes[f[2]];
    const double third = (b - a).cross(c - a).norm() / 6.0;
    for (std::uint32_t n : f) area[n] += third;
    edges.push_back((b - a).norm());
  }
  std::nth_element(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(edges.size() / 2), edges.end());
  const double patch = o.patch_radius > 0 ? o.patch_radius : 2.0 * edges[edges.size() / 2];
  std::vector<std::uint32_t> nodes;  // free boundary nodes
  std::vector<Eigen::Vector3d> places;
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    if (area[n] > 0 && !clamped[3 * n]) {
      nodes.push_back(static_cast<std::uint32_t>(n));
      places.push_back(mesh.nodes[n]);
    }
  const PointGrid grid(places, patch);

  // Each surface vertex's patch: the free boundary nodes within b.
  const std::size_t vertices = model.surface_vertices.size();
  std::vector<std::vector<std::uint32_t>> patches(vertices);
  std::vector<char> needed(nodes.size(), 0);
  for (std::size_t v = 0; v < vertices; ++v) {
    patches[v] = grid.within(point(model.surface_vertices[v]), patch);
    for (std::uint32_t p : patches[v]) needed[p] = 1;
  }
  // The contacts a press may lift: their boundary nodes are solved too, and
  // every solve keeps how far each contact moves along its normal.
  std::vector<std::uint32_t> contact_node;  // index into `nodes`, per liftable spring
  {
    std::unordered_map<std::uint32_t, std::uint32_t> boundary_index;
    for (std::uint32_t a = 0; a < nodes.size(); ++a) boundary_index.emplace(nodes[a], a);
    for (const fem::FoundationSpring& spring : liftable) {
      const auto found = boundary_index.find(static_cast<std::uint32_t>(spring.node));
      if (found == boundary_index.end())
        throw std::logic_error("a contact's foundation spring is not on a free boundary node");
      contact_node.push_back(found->second);
      needed[found->second] = 1;
    }
  }
  const auto contacts = static_cast<Eigen::Index>(liftable.size());

  // The boundary's Green's function between needed nodes closer than 2b:
  // per node a, for each such node b, the 3×3 displacement of b per unit
  // force at a (column: the force's direction).
  struct Response {
    std::uint32_t node;
    Eigen::Matrix3d displacement;
  };
  std::vector<std::vector<Response>> green(nodes.size());
  // Per solved node a, each liftable contact's normal displacement per unit
  // force at a (contacts × 3).
  std::vector<Eigen::MatrixXd> toward_contacts(contacts > 0 ? nodes.size() : 0);
  std::vector<int> contact_rows;
  for (const fem::FoundationSpring& spring : liftable)
    for (int k = 0; k < 3; ++k)
      contact_rows.push_back(system.free_index()[3 * static_cast<std::size_t>(spring.node) + k]);
  std::vector<std::uint32_t> solved;
  for (std::uint32_t a = 0; a < nodes.size(); ++a)
    if (needed[a]) solved.push_back(a);
  const std::vector<std::int32_t>& free_index = system.free_index();
  const auto solve_start = std::chrono::steady_clock::now();
  // Blocks of BlockSolver::kBlock / 3 nodes (three directions each), in a
  // fixed order: the threads take whole blocks. Nodes in the factor's
  // elimination order, so that a block's loads share most of their paths
  // to the root (a block then reads little more of L than one load).
  const BlockSolver solver(factor);
  {
    const int* order = factor.permutationP().indices().data();
    std::sort(solved.begin(), solved.end(), [&](std::uint32_t a, std::uint32_t b) {
      return order[free_index[3 * nodes[a]]] < order[free_index[3 * nodes[b]]];
    });
  }
  constexpr int kNodesPerBlock = BlockSolver::kBlock / 3;
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    BlockSolver::Block block(system.free_count(), BlockSolver::kBlock);
    BlockSolver::Workspace workspace = solver.workspace();
    std::vector<int> loaded, wanted;
    std::vector<std::vector<std::uint32_t>> near(kNodesPerBlock);
    for (std::size_t first; (first = kNodesPerBlock * next.fetch_add(1)) < solved.size();) {
      const std::size_t count = std::min<std::size_t>(kNodesPerBlock, solved.size() - first);
      loaded.clear();
      wanted.clear();
      for (std::size_t m = 0; m < count; ++m) {
        const std::uint32_t a = solved[first + m];
        for (int k = 0; k < 3; ++k) {
          const int row = free_index[3 * nodes[a] + k];
          block.row(row).setZero();
          block(row, static_cast<int>(3 * m) + k) = 1.0;
          loaded.push_back(row);
        }
        near[m].clear();
        for (std::uint32_t b : grid.within(places[a], 2.0 * patch))
          if (needed[b]) {
            near[m].push_back(b);
            for (int k = 0; k < 3; ++k) wanted.push_back(free_index[3 * nodes[b] + k]);
          }
      }
      wanted.insert(wanted.end(), contact_rows.begin(), contact_rows.end());
      solver.solve(block, loaded, wanted, workspace);
      for (std::size_t m = 0; m < count; ++m) {
        const std::uint32_t a = solved[first + m];
        if (contacts > 0) {
          Eigen::MatrixXd& toward = toward_contacts[a];
          toward.resize(contacts, 3);
          for (Eigen::Index j = 0; j < contacts; ++j)
            for (int k = 0; k < 3; ++k) {
              double along = 0.0;
              for (int r = 0; r < 3; ++r)
                along += liftable[static_cast<std::size_t>(j)].normal[r] *
                         block(contact_rows[static_cast<std::size_t>(3 * j + r)], static_cast<int>(3 * m) + k);
              toward(j, k) = along;
            }
        }
        for (std::uint32_t b : near[m]) {
          Response r{b, Eigen::Matrix3d::Zero()};
          for (int k = 0; k < 3; ++k)
            r.displacement.row(k) =
                block.row(free_index[3 * nodes[b] + k]).segment<3>(static_cast<Eigen::Index>(3 * m));
          green[a].push_back(r);
        }
      }
    }
  };
  const unsigned threads = std::max(1u, o.threads > 0 ? o.threads : std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  const double solve_seconds = seconds_since(solve_start);

  // The liftable contacts' normal compliance among themselves, and their springs.
  Eigen::MatrixXd among_contacts(contacts, contacts);
  Eigen::VectorXd springs(contacts);
  for (Eigen::Index j = 0; j < contacts; ++j) {
    among_contacts.col(j) =
        toward_contacts[contact_node[static_cast<std::size_t>(j)]] * liftable[static_cast<std::size_t>(j)].normal;
    springs[j] = liftable[static_cast<std::size_t>(j)].stiffness;
  }
  among_contacts = 0.5 * (among_contacts + among_contacts.transpose()).eval();
  Eigen::MatrixXd contacts_inverse;  // (K⁻¹ − G)⁻¹ over every contact
  if (contacts > 0) {
    Eigen::MatrixXd released_all = -among_contacts;
    released_all.diagonal() += springs.cwiseInverse();
    const Eigen::LLT<Eigen::MatrixXd> all(released_all);
    if (all.info() == Eigen::Success) contacts_inverse = all.solve(Eigen::MatrixXd::Identity(contacts, contacts));
  }

  // Each site: the patch's mean displacement per unit force, less the
  // patch's own indentation; with liftable contacts, as the site's press
  // finds them.
  const std::vector<Eigen::Vector3d> normals = vertex_normals(model);
  const double young = model.material.young_modulus;
  std::vector<std::array<double, 6>> compliance(vertices);
  std::atomic<std::size_t> next_run{0}, unsettled{0};
  auto sites = [&] {
    std::vector<double> weight(nodes.size(), 0.0);
    Eigen::MatrixXd toward(contacts, 3);
    ReleasedContacts released(among_contacts, springs, contacts_inverse);
    // The patch's mean normal displacement of each contact per unit force.
    auto toward_from = [&](std::size_t v) {
      double total = 0.0;
      for (std::uint32_t p : patches[v]) total += area[nodes[p]];
      toward.setZero();
      for (std::uint32_t p : patches[v]) toward += (area[nodes[p]] / total) * toward_contacts[p];
      return total > 0.0;
    };
    for (std::size_t first; (first = kSitesPerRun * next_run.fetch_add(1)) < vertices;)
      for (std::size_t v = first, last = std::min(vertices, first + kSitesPerRun); v < last; ++v) {
        if (v == first) released.clear();
        double total = 0.0;
        for (std::uint32_t p : patches[v]) total += area[nodes[p]];
        if (!(total > 0.0)) {
          compliance[v] = {};  // at the clamp: the organ does not give
          continue;
        }
        for (std::uint32_t p : patches[v]) weight[p] = area[nodes[p]] / total;
        Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
        for (std::uint32_t a : patches[v])
          for (const Response& r : green[a]) c += weight[a] * weight[r.node] * r.displacement;
        if (contacts > 0) {
          toward_from(v);
          if (!released.settle(toward, normals[v])) ++unsettled;
          c += released.gained(toward);
        }
        for (std::uint32_t p : patches[v]) weight[p] = 0.0;
        c = 0.5 * (c + c.transpose()) -
            organ::disk_compliance(young, o.poisson_ratio, std::sqrt(total / M_PI), normals[v]);
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(c);
        c = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
        compliance[v] = packed(c);
      }
  };
  pool.clear();
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(sites);
  sites();
  for (std::thread& t : pool) t.join();
  report.patch_radius = patch;
  report.boundary_nodes = solved.size();
  report.unsettled_sites += unsettled;
  report.unknowns = static_cast<std::size_t>(system.free_count());
  report.factor_entries = solver.factor_entries();
  report.factorization_seconds += factorization_seconds;
  report.solve_seconds += solve_seconds;
  return compliance;
}

/// `tangent` with the supports `springs` (fem::foundation_springs') held
/// both ways: every contact pushed into (K n nᵀ, its spring along the
/// normal) and every attachment (K I), linear about rest.
fem::SparseMatrix on_supports(const std::vector<fem::FoundationSpring>& springs, const fem::ElasticitySystem& system,
                              const fem::SparseMatrix& tangent) {
  std::vector<Eigen::Triplet<double>> entries;
  const std::vector<std::int32_t>& free_index = system.free_index();
  for (const fem::FoundationSpring& spring : springs) {
    const Eigen::Matrix3d block = spring.unilateral
                                      ? Eigen::Matrix3d(spring.stiffness * spring.normal * spring.normal.transpose())
                                      : Eigen::Matrix3d(spring.stiffness * Eigen::Matrix3d::Identity());
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        entries.emplace_back(free_index[3 * static_cast<std::size_t>(spring.node) + r],
                             free_index[3 * static_cast<std::size_t>(spring.node) + c], block(r, c));
  }
  fem::SparseMatrix foundation(tangent.rows(), tangent.cols());
  foundation.setFromTriplets(entries.begin(), entries.end());
  return tangent + foundation;
}

}  // namespace

std::vector<std::array<double, 2>> site_curvatures(const model::OrganModel& model, double radius) {
  if (!(radius > 0) || !std::isfinite(radius))
    throw std::invalid_argument("the curvature's fit radius must be a length > 0");
  std::vector<Eigen::Vector3d> places;
  places.reserve(model.surface_vertices.size());
  for (const model::Point3& p : model.surface_vertices) places.push_back(point(p));
  const PointGrid grid(places, radius);
  const std::vector<Eigen::Vector3d> normals = vertex_normals(model);
  std::vector<std::array<double, 2>> curvature(places.size(), {0.0, 0.0});
  std::vector<Eigen::Vector3d> near;
  for (std::size_t v = 0; v < places.size(); ++v) {
    near.clear();
    // Only the surface facing the same side: across a thin lobe the ball
    // reaches the far face, which is no part of this one's shape.
    for (std::uint32_t p : grid.within(places[v], radius))
      if (p != v && normals[p].dot(normals[v]) > 0.0) near.push_back(places[p]);
    // Five unknowns: with fewer points the quadric is undetermined, and the
    // site is taken as flat (the tip alone sets the Hertz radius).
    if (near.size() >= 5) curvature[v] = fitted_curvatures(places[v], normals[v], near);
  }
  return curvature;
}

model::SiteCompliance compute_site_compliance(const model::OrganModel& model, const SiteComplianceOptions& o,
                                              SiteComplianceReport* report) {
  if (model.tetrahedra.empty() || model.volume_vertices.empty())
    throw std::invalid_argument("site compliances need the model's tetrahedra");
  if (!(o.poisson_ratio > 0 && o.poisson_ratio < 0.5))
    throw std::invalid_argument("the reference's Poisson's ratio must lie in (0, 0.5)");
  if (!(o.stabilization >= 0) || !std::isfinite(o.stabilization))
    throw std::invalid_argument("the reference's stabilization must be a finite number >= 0");
  if (!(o.patch_radius >= 0) || !std::isfinite(o.patch_radius))
    throw std::invalid_argument("the patch radius must be a length >= 0");
  if (!(o.curvature_radius >= 0) || !std::isfinite(o.curvature_radius))
    throw std::invalid_argument("the curvature's fit radius must be a length >= 0");
  if (!(o.fixed_radius > 0) || !std::isfinite(o.fixed_radius))
    throw std::invalid_argument("the clamp radius must be a length > 0");

  // The PSH stiffness at rest, clamped as the FEM models clamp it.
  const fem::TetMesh mesh = fem::tet_mesh_of(model);
  const std::vector<bool> clamped = fem::clamped_dofs(model, o.fixed_radius);
  const double young = model.material.young_modulus;
  fem::ElasticitySystem system(mesh, fem::Material::mooney_rivlin_from_young(young, o.poisson_ratio, o.stabilization),
                               clamped);
  Eigen::VectorXd state = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
  system.assemble(state, gradient, true);
  SiteComplianceReport measured;
  model::SiteCompliance sites;
  sites.young_modulus = young;
  sites.poisson_ratio = o.poisson_ratio;
  sites.compliance = organ_compliances(model, system, system.tangent_free(), clamped, {}, o, measured);
  if (o.supports && !model.supports.empty()) {
    const std::vector<fem::FoundationSpring> springs =
        fem::foundation_springs(model, clamped, geometry::tetrahedral_boundary(model.tetrahedra));
    std::vector<fem::FoundationSpring> contacts;
    for (const fem::FoundationSpring& spring : springs)
      if (spring.unilateral && o.settle_contacts) contacts.push_back(spring);
    sites.supported = organ_compliances(model, system, on_supports(springs, system, system.tangent_free()), clamped,
                                        contacts, o, measured);
  }
  std::vector<double> surface_edges;
  for (const model::Triangle& t : model.surface_triangles)
    surface_edges.push_back((point(model.surface_vertices[t[1]]) - point(model.surface_vertices[t[0]])).norm());
  double curvature_radius = o.curvature_radius;
  if (!(curvature_radius > 0)) {
    curvature_radius = kDefaultCurvatureRadius;
    if (!surface_edges.empty()) {
      const auto middle = surface_edges.begin() + static_cast<std::ptrdiff_t>(surface_edges.size() / 2);
      std::nth_element(surface_edges.begin(), middle, surface_edges.end());
      curvature_radius = std::max(curvature_radius, 2.0 * *middle);
    }
  }
  sites.curvature = site_curvatures(model, curvature_radius);
  measured.curvature_radius = curvature_radius;
  if (report) *report = measured;
  return sites;
}

}  // namespace organsim::pipeline
