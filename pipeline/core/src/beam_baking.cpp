#include "organsim/pipeline/beam_baking.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <thread>

namespace organsim::pipeline {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMetresPerMillimetre = 1e-3;
constexpr int kBlockShift = 2;  // blocks of 4³ voxels
constexpr long kBlock = 1L << kBlockShift;
enum BlockState : std::uint8_t { kEmpty, kFull, kMixed };
// The coarse pass of a section samples every kCoarseStep-th grid point.
constexpr unsigned kCoarseStep = 4;

}  // namespace

MaskSampler::MaskSampler(const MaskImage& mask) : mask_(mask) {
  const auto size = mask.GetLargestPossibleRegion().GetSize();
  const auto spacing = mask.GetSpacing();
  const auto origin = mask.GetOrigin();
  const auto inverse = mask.GetInverseDirection();
  for (int r = 0; r < 3; ++r) {
    size_[r] = static_cast<long>(size[r]);
    offset_[r] = 0.0;
    for (int c = 0; c < 3; ++c) {
      // index = D⁻¹ (p − o) / s, with p in mm = 1000 × metres.
      to_index_[r][c] = inverse[r][c] / spacing[r] / kMetresPerMillimetre;
      offset_[r] -= inverse[r][c] * origin[c] / spacing[r];
    }
  }
  // Bounding sphere of the organ's voxels, from the index bounding box.
  long lo[3] = {size_[0], size_[1], size_[2]}, hi[3] = {-1, -1, -1};
  const std::uint8_t* v = mask.GetBufferPointer();
  for (long k = 0, n = 0; k < size_[2]; ++k)
    for (long j = 0; j < size_[1]; ++j)
      for (long i = 0; i < size_[0]; ++i, ++n)
        if (v[n]) {
          lo[0] = std::min(lo[0], i), hi[0] = std::max(hi[0], i);
          lo[1] = std::min(lo[1], j), hi[1] = std::max(hi[1], j);
          lo[2] = std::min(lo[2], k), hi[2] = std::max(hi[2], k);
        }
  // Block b holds the samples whose base voxel lies in [4b, 4b + 3]; their
  // trilinear corners span voxels [4b, 4b + 4] along each axis.
  for (int r = 0; r < 3; ++r) blocks_[r] = (size_[r] + kBlock - 1) / kBlock;
  block_.assign(static_cast<std::size_t>(blocks_[0] * blocks_[1] * blocks_[2]), kEmpty);
  mixed_of_block_.assign(block_.size(), 0);
  for (long bk = 0, b = 0; bk < blocks_[2]; ++bk)
    for (long bj = 0; bj < blocks_[1]; ++bj)
      for (long bi = 0; bi < blocks_[0]; ++bi, ++b) {
        const long first[3] = {bi * kBlock, bj * kBlock, bk * kBlock};
        bool any = false, all = true;
        std::array<std::uint64_t, 2> bits{};
        for (long k = first[2], bit = 0; k <= first[2] + kBlock; ++k)
          for (long j = first[1]; j <= first[1] + kBlock; ++j)
            for (long i = first[0]; i <= first[0] + kBlock; ++i, ++bit) {
              const bool in_volume = i < size_[0] && j < size_[1] && k < size_[2];
              const bool set = in_volume && v[(k * size_[1] + j) * size_[0] + i] != 0;
              any |= set;
              all &= set;
              if (set) bits[static_cast<std::size_t>(bit >> 6)] |= std::uint64_t{1} << (bit & 63);
            }
        block_[static_cast<std::size_t>(b)] = all ? kFull : any ? kMixed : kEmpty;
        if (block_[static_cast<std::size_t>(b)] == kMixed) {
          mixed_of_block_[static_cast<std::size_t>(b)] = static_cast<std::uint32_t>(mixed_bits_.size());
          mixed_bits_.push_back(bits);
        }
      }
  if (hi[0] < 0) return;  // empty mask: radius 0
  MaskImage::PointType a, b;
  mask.TransformContinuousIndexToPhysicalPoint(
      itk::ContinuousIndex<double, 3>(std::array<double, 3>{lo[0] - 1.0, lo[1] - 1.0, lo[2] - 1.0}.data()), a);
  mask.TransformContinuousIndexToPhysicalPoint(
      itk::ContinuousIndex<double, 3>(std::array<double, 3>{hi[0] + 1.0, hi[1] + 1.0, hi[2] + 1.0}.data()), b);
  for (int k = 0; k < 3; ++k) centre_[k] = 0.5 * (a[k] + b[k]) * kMetresPerMillimetre;
  radius_ = 0.5 * std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]) * kMetresPerMillimetre;
}

MaskSampler::Index MaskSampler::index_of(const model::Point3& p) const {
  Index index;
  for (int r = 0; r < 3; ++r)
    index[r] = to_index_[r][0] * p[0] + to_index_[r][1] * p[1] + to_index_[r][2] * p[2] + offset_[r];
  return index;
}

double MaskSampler::value(const model::Point3& p) const { return value_at(index_of(p)); }

bool MaskSampler::inside(const Index& index) const {
  // Samples whose base voxel is inside the volume use the block table; the
  // rest (the volume's border, NaN) take the exact path.
  if (index[0] >= 0.0 && index[1] >= 0.0 && index[2] >= 0.0 && index[0] < size_[0] && index[1] < size_[1] &&
      index[2] < size_[2]) {
    const long i = static_cast<long>(index[0]) >> kBlockShift, j = static_cast<long>(index[1]) >> kBlockShift,
               k = static_cast<long>(index[2]) >> kBlockShift;
    const std::size_t block = static_cast<std::size_t>((k * blocks_[1] + j) * blocks_[0] + i);
    if (block_[block] != kMixed) return block_[block] == kFull;
    const long base[3] = {static_cast<long>(index[0]), static_cast<long>(index[1]), static_cast<long>(index[2])};
    if (base[0] + 1 < size_[0] && base[1] + 1 < size_[1] && base[2] + 1 < size_[2]) {
      // value_at's sum, term by term in its order, on the block's bits.
      const std::array<std::uint64_t, 2>& bits = mixed_bits_[mixed_of_block_[block]];
      const long low = ((base[2] & (kBlock - 1)) * (kBlock + 1) + (base[1] & (kBlock - 1))) * (kBlock + 1) +
                       (base[0] & (kBlock - 1));
      constexpr long kRow = kBlock + 1, kSlice = kRow * kRow;
      const long step[8] = {0, 1, kRow, kRow + 1, kSlice, kSlice + 1, kSlice + kRow, kSlice + kRow + 1};
      const double fraction[3] = {index[0] - static_cast<double>(base[0]), index[1] - static_cast<double>(base[1]),
                                  index[2] - static_cast<double>(base[2])};
      double sum = 0.0;
      for (int corner = 0; corner < 8; ++corner) {
        const double weight = ((corner & 1) ? fraction[0] : 1.0 - fraction[0]) *
                              ((corner & 2) ? fraction[1] : 1.0 - fraction[1]) *
                              ((corner & 4) ? fraction[2] : 1.0 - fraction[2]);
        const long bit = low + step[corner];
        const double value = static_cast<double>((bits[static_cast<std::size_t>(bit >> 6)] >> (bit & 63)) & 1);
        if (weight != 0.0) sum += weight * value;
      }
      return sum >= 0.5;
    }
  }
  return value_at(index) >= 0.5;
}

double MaskSampler::value_at(const Index& index) const {
  long base[3];
  double fraction[3];
  for (int r = 0; r < 3; ++r) {
    const double f = std::floor(index[r]);
    if (!(f >= -1.0 && f < static_cast<double>(size_[r]))) return 0.0;
    base[r] = static_cast<long>(f);
    fraction[r] = index[r] - f;
  }
  const std::uint8_t* v = mask_.GetBufferPointer();
  if (base[0] >= 0 && base[1] >= 0 && base[2] >= 0 && base[0] + 1 < size_[0] && base[1] + 1 < size_[1] &&
      base[2] + 1 < size_[2]) {
    // All eight corners inside the volume (nearly every sample): no checks,
    // the same sum in the same order as below.
    const long row = size_[0], slice = size_[0] * size_[1];
    const std::uint8_t* p = v + (base[2] * size_[1] + base[1]) * size_[0] + base[0];
    const long step[8] = {0, 1, row, row + 1, slice, slice + 1, slice + row, slice + row + 1};
    double sum = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
      const double weight = ((corner & 1) ? fraction[0] : 1.0 - fraction[0]) *
                            ((corner & 2) ? fraction[1] : 1.0 - fraction[1]) *
                            ((corner & 4) ? fraction[2] : 1.0 - fraction[2]);
      if (weight != 0.0) sum += weight * p[step[corner]];
    }
    return sum;
  }
  double sum = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    long at[3];
    double weight = 1.0;
    for (int r = 0; r < 3; ++r) {
      const int upper = (corner >> r) & 1;
      at[r] = base[r] + upper;
      weight *= upper ? fraction[r] : 1.0 - fraction[r];
    }
    if (weight == 0.0 || at[0] < 0 || at[1] < 0 || at[2] < 0 || at[0] >= size_[0] || at[1] >= size_[1] ||
        at[2] >= size_[2])
      continue;
    sum += weight * v[(at[2] * size_[1] + at[1]) * size_[0] + at[0]];
  }
  return sum;
}

model::BeamSection organ_section(const MaskSampler& sampler, const model::Point3& c, const model::BeamFrame& frame,
                                 unsigned n) {
  model::BeamSection section;
  // The section lies in the disc where the plane cuts the organ's bounding sphere.
  const model::Point3& o = sampler.organ_centre();
  const double along = (o[0] - c[0]) * frame.x[0] + (o[1] - c[1]) * frame.x[1] + (o[2] - c[2]) * frame.x[2];
  const double disc2 = sampler.organ_radius() * sampler.organ_radius() - along * along;
  if (disc2 <= 0.0 || n < 2) return section;
  const double half = std::sqrt(disc2);
  const double oy = (o[0] - c[0]) * frame.y[0] + (o[1] - c[1]) * frame.y[1] + (o[2] - c[2]) * frame.y[2];
  const double oz = (o[0] - c[0]) * frame.z[0] + (o[1] - c[1]) * frame.z[1] + (o[2] - c[2]) * frame.z[2];
  const double h = 2.0 * half / n;
  auto local = [&](unsigned i, unsigned j) {
    return std::array<double, 2>{oy - half + (i + 0.5) * h, oz - half + (j + 0.5) * h};
  };
  // Grid point (i, j) has the continuous voxel index first + i di + j dj.
  auto physical = [&](double y, double z) {
    return model::Point3{c[0] + y * frame.y[0] + z * frame.z[0], c[1] + y * frame.y[1] + z * frame.z[1],
                         c[2] + y * frame.y[2] + z * frame.z[2]};
  };
  const auto [y0, z0] = local(0, 0);
  const MaskSampler::Index first = sampler.index_of(physical(y0, z0)), along_i = sampler.index_of(physical(y0 + h, z0)),
                           along_j = sampler.index_of(physical(y0, z0 + h));
  const double di[3] = {along_i[0] - first[0], along_i[1] - first[1], along_i[2] - first[2]};
  const double dj[3] = {along_j[0] - first[0], along_j[1] - first[1], along_j[2] - first[2]};
  auto inside_at = [&](unsigned i, unsigned j) {
    return sampler.inside(
        {first[0] + i * di[0] + j * dj[0], first[1] + i * di[1] + j * dj[1], first[2] + i * di[2] + j * dj[2]});
  };
  // Coarse pass: the organ's extent in the plane, plus one coarse step, plus
  // the neighbourhood of the axis point (small sections near the beam's tip).
  long lo_i = n, hi_i = -1, lo_j = n, hi_j = -1;
  auto include = [&](long i, long j) {
    lo_i = std::min(lo_i, i), hi_i = std::max(hi_i, i), lo_j = std::min(lo_j, j), hi_j = std::max(hi_j, j);
  };
  for (unsigned j = kCoarseStep / 2; j < n; j += kCoarseStep)
    for (unsigned i = kCoarseStep / 2; i < n; i += kCoarseStep)
      if (inside_at(i, j)) include(i, j);
  const double axis_i = (half - oy) / h - 0.5, axis_j = (half - oz) / h - 0.5;
  if (axis_i >= 0.0 && axis_i < n && axis_j >= 0.0 && axis_j < n)
    include(static_cast<long>(axis_i), static_cast<long>(axis_j));
  if (hi_i < 0) return section;
  lo_i = std::max(0L, lo_i - static_cast<long>(kCoarseStep)),
  hi_i = std::min(n - 1L, hi_i + static_cast<long>(kCoarseStep));
  lo_j = std::max(0L, lo_j - static_cast<long>(kCoarseStep)),
  hi_j = std::min(n - 1L, hi_j + static_cast<long>(kCoarseStep));
  // The fine pass covers the coarse extent only; samples outside it count as
  // outside. Buffers are reused per thread: a bake calls this 100,000 times.
  const std::size_t width = static_cast<std::size_t>(hi_i - lo_i + 1),
                    height = static_cast<std::size_t>(hi_j - lo_j + 1);
  constexpr std::uint8_t kUnknown = 0, kOutside = 1, kInside = 2, kTaken = 3;
  thread_local std::vector<std::uint8_t> state;
  thread_local std::vector<std::size_t> stack;
  state.assign(width * height, kUnknown);
  const auto sampled = [&](std::size_t at) {
    if (state[at] == kUnknown)
      state[at] = inside_at(static_cast<unsigned>(lo_i + static_cast<long>(at % width)),
                            static_cast<unsigned>(lo_j + static_cast<long>(at / width)))
                      ? kInside
                      : kOutside;
    return state[at];
  };
  // The connected piece containing the axis point, or the piece nearest to it:
  // its start is the inside cell whose centre is nearest to the axis point
  // (the first in row order among equals). The nearest of all cells is one of
  // the four around the axis point; when it is inside it is the start, and
  // only the piece and its rim are sampled. Otherwise every cell of the
  // extent is.
  const auto distance2 = [&](std::size_t at) {
    const auto [y, z] = local(static_cast<unsigned>(lo_i + static_cast<long>(at % width)),
                              static_cast<unsigned>(lo_j + static_cast<long>(at / width)));
    return y * y + z * z;
  };
  std::size_t start = state.size(), nearest_cell = state.size();
  double nearest = std::numeric_limits<double>::infinity();
  const long below_i = static_cast<long>(std::floor(axis_i)), below_j = static_cast<long>(std::floor(axis_j));
  for (long j = below_j; j <= below_j + 1; ++j)
    for (long i = below_i; i <= below_i + 1; ++i)
      if (i >= lo_i && i <= hi_i && j >= lo_j && j <= hi_j) {
        const std::size_t at = static_cast<std::size_t>(j - lo_j) * width + static_cast<std::size_t>(i - lo_i);
        if (const double d = distance2(at); d < nearest) nearest = d, nearest_cell = at;
      }
  if (nearest_cell < state.size() && sampled(nearest_cell) == kInside) start = nearest_cell;
  if (start == state.size()) {
    nearest = std::numeric_limits<double>::infinity();
    for (std::size_t at = 0; at < state.size(); ++at)
      if (sampled(at) == kInside)
        if (const double d = distance2(at); d < nearest) nearest = d, start = at;
  }
  if (start == state.size()) return section;
  stack.assign(1, start);
  state[start] = kTaken;
  double count = 0, sy = 0, sz = 0, syy = 0, szz = 0, syz = 0;
  while (!stack.empty()) {
    const std::size_t at = stack.back();
    stack.pop_back();
    const std::size_t i = at % width, j = at / width;
    const auto [y, z] =
        local(static_cast<unsigned>(lo_i + static_cast<long>(i)), static_cast<unsigned>(lo_j + static_cast<long>(j)));
    count += 1;
    sy += y, sz += z, syy += y * y, szz += z * z, syz += y * z;
    const std::size_t neighbours[4] = {i > 0 ? at - 1 : at, i + 1 < width ? at + 1 : at, j > 0 ? at - width : at,
                                       j + 1 < height ? at + width : at};
    for (std::size_t next : neighbours)
      if (sampled(next) == kInside) state[next] = kTaken, stack.push_back(next);
  }
  const double cell = h * h;
  section.area = count * cell;
  section.centroid_y = sy / count;
  section.centroid_z = sz / count;
  // Each sample is an h × h square: add its own second moment h²/12.
  section.i_yy = (szz / count - section.centroid_z * section.centroid_z + h * h / 12.0) * section.area;
  section.i_zz = (syy / count - section.centroid_y * section.centroid_y + h * h / 12.0) * section.area;
  section.i_yz = (syz / count - section.centroid_y * section.centroid_z) * section.area;
  // Saint-Venant's approximation J ≈ A⁴ / (4π² I_p): exact for ellipses, and
  // never above the polar moment I_p as J of a general section must be.
  section.torsion_j = std::pow(section.area, 4) / (4.0 * kPi * kPi * (section.i_yy + section.i_zz));
  return section;
}

model::BeamTables bake_beam_tables(const MaskImage& mask, const std::vector<model::Point3>& vertices,
                                   const model::Point3& fixed_point, const BeamBakingOptions& options,
                                   const std::function<void(double)>& progress) {
  const MaskSampler sampler(mask);
  model::BeamTables tables;
  tables.stations_per_beam = options.stations;
  tables.sections.resize(vertices.size() * options.stations);
  std::atomic<std::size_t> next{0};
  auto work = [&](bool reports) {
    for (std::size_t v = next++; v < vertices.size(); v = next++) {
      if (reports && progress && v % 64 == 0 && v > 0) progress(static_cast<double>(v) / vertices.size());
      model::BeamFrame frame;
      if (!model::make_beam_frame(fixed_point, vertices[v], frame))
        continue;  // vertex at the fixed point: zero sections
      for (std::uint32_t s = 0; s < options.stations; ++s) {
        const double t = (s + 0.5) / options.stations;
        const model::Point3 axis_point{fixed_point[0] + t * (vertices[v][0] - fixed_point[0]),
                                       fixed_point[1] + t * (vertices[v][1] - fixed_point[1]),
                                       fixed_point[2] + t * (vertices[v][2] - fixed_point[2])};
        tables.sections[v * options.stations + s] = organ_section(sampler, axis_point, frame, options.samples_per_side);
      }
    }
  };
  const unsigned threads = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work, false);
  work(true);
  for (std::thread& t : pool) t.join();
  return tables;
}

}  // namespace organsim::pipeline
