// The per-vertex kernels, compiled once per instruction set (vertex_kernels.h): the
// build passes ORGANSIM_KERNEL_LEVEL (a namespace name) and the -march of the
// level. Uses only builtins and vector_math.h, which lives in the same
// per-level namespace, so that no inline code is shared with other objects.
#include "organsim/vertex_kernels/vertex_kernels.h"
#include "vector_math.h"

namespace organsim::vertex_kernels {
namespace ORGANSIM_KERNEL_LEVEL {
namespace {

// Vertices are processed in blocks so that per-tool distances and weights live
// in small stack arrays and the inner loops run over contiguous vertices.
constexpr std::size_t kBlock = 128;
static_assert(kLanes == kPadding && kLanes == kChunk && kBlock % kLanes == 0);

constexpr std::size_t smaller(std::size_t a, std::size_t b) noexcept { return a < b ? a : b; }

// Where eight vertices (offsets from the fixed point) lie along a beam, in
// elements: τ in [0, stations]. The one expression for build_weights' chunk
// elements and distort().
inline Lanes place_in_elements(const BeamAxis& beam, float stations, Lanes fx, Lanes fy, Lanes fz) noexcept {
  return clamp_lanes(fx * beam.to_elements[0] + fy * beam.to_elements[1] + fz * beam.to_elements[2], 0.0f, stations);
}

// u/2 and a = θ/2 (vertex_kernels.h) at eight places along a beam.
struct BeamValues {
  Lanes ux, uy, uz, ax, ay, az;
};

// A chunk over more than two elements (kept out of distort()'s loop, whose
// registers it would otherwise take): each lane's own element's coefficients.
__attribute__((noinline, cold)) BeamValues values_per_lane(const float* lowest_record, std::int32_t lowest,
                                                           std::int32_t last_element, Lanes tau) noexcept {
  LaneIntegers element = __builtin_convertvector(tau, LaneIntegers);
  element = element > splat_integer(last_element) ? splat_integer(last_element) : element;
  const Lanes xi = tau - __builtin_convertvector(element, Lanes);
  auto c = [&](int k) {
    Lanes value = splat(lowest_record[k]);
    for (std::int32_t e = lowest + 1; e <= last_element && any_lane(element >= e); ++e)
      value = element == e ? splat(lowest_record[(e - lowest) * kCoefficients + k]) : value;
    return value;
  };
  return {((c(9) * xi + c(6)) * xi + c(3)) * xi + c(0),
          ((c(10) * xi + c(7)) * xi + c(4)) * xi + c(1),
          ((c(11) * xi + c(8)) * xi + c(5)) * xi + c(2),
          c(12) + xi * c(15),
          c(13) + xi * c(16),
          c(14) + xi * c(17)};
}

}  // namespace

void build_weights(const WeightJob& job, std::size_t first, std::size_t last) noexcept {
  const double rate = job.attenuation_rate;
  const LaneIntegers last_element = splat_integer(static_cast<std::int32_t>(job.stations) - 1);
  for (std::size_t begin = first; begin < last; begin += kBlock) {
    const std::size_t n = smaller(kBlock, last - begin);
    const double* x = job.rest[0] + begin;
    const double* y = job.rest[1] + begin;
    const double* z = job.rest[2] + begin;
    alignas(64) double weight[kMaxBeams][kBlock];
    if (job.groups > 1) {
      // f(p) = L⁻¹ l(p) / ‖L⁻¹ l(p)‖₁ per vertex, with l(p) the group distances.
      alignas(64) double distance[kMaxBeams][kBlock];
      for (std::uint32_t g = 0; g < job.groups; ++g) {
        const double* p = job.group_points + 3 * g;
        for (std::size_t v = 0; v < n; ++v) {
          const double dx = x[v] - p[0], dy = y[v] - p[1], dz = z[v] - p[2];
          distance[g][v] = __builtin_sqrt(dx * dx + dy * dy + dz * dz);
        }
      }
      alignas(64) double norm[kBlock];
      for (std::size_t v = 0; v < n; ++v) norm[v] = 0.0;
      for (std::uint32_t i = 0; i < job.groups; ++i) {
        for (std::size_t v = 0; v < n; ++v) weight[i][v] = 0.0;
        for (std::uint32_t j = 0; j < job.groups; ++j) {
          const double m = job.inverse[j * job.inverse_stride + i];
          for (std::size_t v = 0; v < n; ++v) weight[i][v] += m * distance[j][v];
        }
        for (std::size_t v = 0; v < n; ++v) norm[v] += __builtin_fabs(weight[i][v]);
      }
      for (std::size_t v = 0; v < n; ++v) norm[v] = norm[v] > 0.0 ? 1.0 / norm[v] : 0.0;
      for (std::uint32_t i = 0; i < job.groups; ++i)
        for (std::size_t v = 0; v < n; ++v) weight[i][v] *= norm[v];
    } else {
      for (std::size_t v = 0; v < n; ++v) weight[0][v] = 1.0;
    }

    for (std::uint32_t b = 0; b < job.beams; ++b) {
      const WeightBeam& beam = job.beam[b];
      const double* w = weight[job.groups > 1 ? beam.group : 0];
      const double px = beam.point[0], py = beam.point[1], pz = beam.point[2], share = beam.share;
      float* factor = beam.weights + begin;
      for (std::size_t v = 0; v < n; ++v) {
        const double dx = x[v] - px, dy = y[v] - py, dz = z[v] - pz;
        factor[v] =
            static_cast<float>(exp_nonpositive(-rate * __builtin_sqrt(dx * dx + dy * dy + dz * dz)) * share * w[v]);
      }
      // Each chunk's elements, from the same single-precision place along the
      // beam that distort() computes; the padding after the last vertex is
      // left out.
      for (std::size_t v = 0; v < n; v += kLanes) {
        const std::size_t vertex = begin + v;
        const Lanes tau =
            place_in_elements(beam.axis, static_cast<float>(job.stations), load_lanes(job.offset[0] + vertex),
                              load_lanes(job.offset[1] + vertex), load_lanes(job.offset[2] + vertex));
        LaneIntegers element = __builtin_convertvector(tau, LaneIntegers);
        element = element > last_element ? last_element : element;
        const std::size_t present = smaller(kLanes, job.vertex_count - vertex);
        std::int32_t lowest = element[0], highest = element[0];
        for (std::size_t lane = 1; lane < present; ++lane) {
          lowest = element[lane] < lowest ? element[lane] : lowest;
          highest = element[lane] > highest ? element[lane] : highest;
        }
        const std::int32_t knots = highest - lowest < 2 ? highest - lowest : 2;
        beam.chunk_elements[vertex / kLanes] = static_cast<std::uint16_t>(lowest | knots << kElementBits);
      }
    }
  }
}

void distort(const DistortionJob& job, std::size_t first, std::size_t last) noexcept {
  const float stations = static_cast<float>(job.stations);
  const std::int32_t last_element = static_cast<std::int32_t>(job.stations) - 1;

  // Single precision: the displacements (millimetres) come out to about 10⁻⁷
  // of themselves plus a few nanometres, far below what a surface mesh or a
  // screen resolves, and eight lanes fit where four doubles would.
  for (std::size_t begin = first; begin < last; begin += kBlock) {
    const std::size_t count = smaller(kBlock, last - begin);
    const std::size_t chunks = (count + kLanes - 1) / kLanes;  // the vertex arrays are padded
    const float* x = job.offset[0] + begin;
    const float* y = job.offset[1] + begin;
    const float* z = job.offset[2] + begin;
    alignas(32) float out_x[kBlock] = {}, out_y[kBlock] = {}, out_z[kBlock] = {};

    for (std::uint32_t b = 0; b < job.beams; ++b) {
      const BeamLanes& beam = job.beam[b];
      const float* step = beam.axis.element_step;
      const float* factor = beam.weights + begin;
      const std::uint16_t* chunk_elements = beam.chunk_elements + begin / kLanes;
      for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
        // The vertex's place along the beam τ (in elements) and its offset
        // from the axis q: recomputed (a few flops) rather than stored, so
        // that a frame reads one weight per vertex and tool from memory.
        const std::size_t v = chunk * kLanes;
        const Lanes fx = load_lanes(x + v), fy = load_lanes(y + v), fz = load_lanes(z + v);
        const Lanes tau = place_in_elements(beam.axis, stations, fx, fy, fz);
        const Lanes qx = fx - tau * step[0], qy = fy - tau * step[1], qz = fz - tau * step[2];

        // A chunk mostly lies in one element (vertices are numbered in Morton
        // order: 72 % of the chunks on the 100k-vertex benchmark sphere), else
        // mostly in two (24 %). build_weights recorded which, so the branch is
        // decided as soon as the entry is read. In two, every lane is
        // evaluated with the record of the lower element, ξ counted from its
        // start, plus the terms of the knot after it, which vanish before the
        // knot. A chunk over more elements (coarse meshes) takes each lane's
        // own element's coefficients: continuing a cubic over several elements
        // would lose the precision that single precision leaves.
        const std::uint32_t entry = chunk_elements[chunk];
        const std::int32_t lowest = static_cast<std::int32_t>(entry & (kMaxStations - 1));
        const std::uint32_t knots = entry >> kElementBits;
        const float* c = beam.coefficients + static_cast<std::size_t>(lowest) * kCoefficients;
        const Lanes xi = tau - static_cast<float>(lowest);
        BeamValues at;
        if (__builtin_expect(knots < 2, 1)) {
          at.ux = ((splat(c[9]) * xi + c[6]) * xi + c[3]) * xi + c[0];
          at.uy = ((splat(c[10]) * xi + c[7]) * xi + c[4]) * xi + c[1];
          at.uz = ((splat(c[11]) * xi + c[8]) * xi + c[5]) * xi + c[2];
          at.ax = c[12] + xi * c[15];
          at.ay = c[13] + xi * c[16];
          at.az = c[14] + xi * c[17];
          if (knots == 1) {
            const float* knot = c + kPolynomialCoefficients;
            const Lanes s = positive_part(xi - 1.0f);
            at.ux += s * ((s * knot[6] + knot[3]) * s + knot[0]);
            at.uy += s * ((s * knot[7] + knot[4]) * s + knot[1]);
            at.uz += s * ((s * knot[8] + knot[5]) * s + knot[2]);
            at.ax += s * knot[9];
            at.ay += s * knot[10];
            at.az += s * knot[11];
          }
        } else {
          at = values_per_lane(c, lowest, last_element, tau);
        }
        const Lanes ux = at.ux, uy = at.uy, uz = at.uz, ax = at.ax, ay = at.ay, az = at.az;

        // u + θ × q + ½ θ × (θ × q) = 2 (u/2 + a × m), m = q + a × q.
        const Lanes mx = qx + ay * qz - az * qy, my = qy + az * qx - ax * qz, mz = qz + ax * qy - ay * qx;
        const Lanes w = load_lanes(factor + v);
        const Lanes twice_w = w + w;
        store_lanes(out_x + v, load_lanes(out_x + v) + twice_w * (ux + ay * mz - az * my));
        store_lanes(out_y + v, load_lanes(out_y + v) + twice_w * (uy + az * mx - ax * mz));
        store_lanes(out_z + v, load_lanes(out_z + v) + twice_w * (uz + ax * my - ay * mx));
      }
    }
    const double* rest_x = job.rest[0] + begin;
    const double* rest_y = job.rest[1] + begin;
    const double* rest_z = job.rest[2] + begin;
    double* out = job.positions + 3 * begin;
    float* packed = job.packed + 4 * begin;
    for (std::size_t v = 0; v < count; ++v) {
      out[3 * v] = rest_x[v] + out_x[v];
      out[3 * v + 1] = rest_y[v] + out_y[v];
      out[3 * v + 2] = rest_z[v] + out_z[v];
      packed[4 * v] = x[v] + out_x[v];
      packed[4 * v + 1] = y[v] + out_y[v];
      packed[4 * v + 2] = z[v] + out_z[v];
      packed[4 * v + 3] = 0.0f;
    }
  }
}

void normals(const NormalsJob& job, std::size_t first, std::size_t last) noexcept {
  // Eight vertices at a time, one per lane (organ::Organ::ring_rows), in slices
  // of as many as a register holds: each row gathers one neighbour per
  // vertex. Neighbours are taken relative to the centre (which cancels in
  // exact arithmetic) to keep the products small: edges are millimetres,
  // coordinates decimetres.
  const double* x = job.positions;
  const double* y = job.positions + 1;
  const double* z = job.positions + 2;
  for (std::size_t group = first / kLanes; group * kLanes < last; ++group) {
    const std::uint32_t* rows = job.rows + kLanes * job.row_offsets[group];
    const std::uint32_t* end = job.rows + kLanes * job.row_offsets[group + 1];
    for (std::size_t slice = 0; slice < kLanes; slice += kDoubleLanes) {
      const std::size_t base = group * kLanes + slice;
      if (base + kDoubleLanes <= first || base >= last) continue;
      std::uint32_t centre[kDoubleLanes];  // the last group's missing vertices: the last vertex
      for (std::size_t l = 0; l < kDoubleLanes; ++l)
        centre[l] = static_cast<std::uint32_t>(16 * smaller(base + l, job.vertex_count - 1));
      const DoubleLanes cx = gather(x, centre), cy = gather(y, centre), cz = gather(z, centre);
      const std::uint32_t* previous = end - kLanes + slice;
      DoubleLanes ax = gather(x, previous) - cx, ay = gather(y, previous) - cy, az = gather(z, previous) - cz;
      DoubleLanes sx{}, sy{}, sz{};
      for (const std::uint32_t* row = rows + slice; row < end; row += kLanes) {
        const DoubleLanes bx = gather(x, row) - cx, by = gather(y, row) - cy, bz = gather(z, row) - cz;
        sx += ay * bz - az * by;
        sy += az * bx - ax * bz;
        sz += ax * by - ay * bx;
        ax = bx;
        ay = by;
        az = bz;
      }
      const DoubleLanes squared = sx * sx + sy * sy + sz * sz;
      const DoubleLanes inverse = 1.0 / square_root(squared);  // ∞ where 0: not taken
      const DoubleLanes scale = squared > 0.0 ? inverse : DoubleLanes{};
      const DoubleLanes nx = sx * scale, ny = sy * scale, nz = sz * scale;

      const std::size_t from = first > base ? first - base : 0;
      const std::size_t to = smaller(kDoubleLanes, last - base);
      double* out = job.normals + 3 * base;
      for (std::size_t l = from; l < to; ++l) {
        out[3 * l] = nx[l];
        out[3 * l + 1] = ny[l];
        out[3 * l + 2] = nz[l];
      }
    }
  }
}

void packed_normals(const PackedNormalsJob& job, std::size_t first, std::size_t last) noexcept {
  // As normals(), on single-precision points of 16 bytes: one load per
  // neighbour, several vertices per register (kPackedVertices), the cross
  // product of whole points through yzx. Two sums (a ∘ yzx(b) and
  // yzx(a) ∘ b) so that each term is one fused multiply-add.
  const float* packed = job.packed;
  for (std::size_t group = first / kLanes; group * kLanes < last; ++group) {
    const std::uint32_t* rows = job.rows + kLanes * job.row_offsets[group];
    const std::uint32_t* end = job.rows + kLanes * job.row_offsets[group + 1];
    PackedGroup normal;  // per vertex: yzx of twice its normal, then its unit normal
    for (std::size_t slice = 0; slice < kPackedSlices; ++slice) {
      // The last group's missing vertices read the padding: their lanes are not written.
      const PackedLanes centre = load_packed_run(packed + 4 * (group * kLanes + slice * kPackedVertices));
      PackedLanes a = load_packed(packed, end - kLanes + slice * kPackedVertices) - centre;
      PackedLanes a_yzx = yzx(a);
      PackedLanes plus{}, minus{};
      for (const std::uint32_t* row = rows + slice * kPackedVertices; row < end; row += kLanes) {
        const PackedLanes b = load_packed(packed, row) - centre;
        const PackedLanes b_yzx = yzx(b);
        plus += a * b_yzx;
        minus += a_yzx * b;
        a = b;
        a_yzx = b_yzx;
      }
      normal[slice] = yzx(plus - minus);
    }
    normalize(normal);

    const std::size_t base = group * kLanes;
    double* out = job.normals + 3 * base;
    if (base >= first && base + kLanes < last) {  // the whole group, and the vertex after it
      for (std::size_t slice = 0; slice < kPackedSlices; ++slice)
        store_as_doubles(out + 3 * kPackedVertices * slice, normal[slice]);
      continue;
    }
    const std::size_t from = first > base ? first - base : 0;
    const std::size_t to = smaller(kLanes, last - base);
    for (std::size_t l = from; l < to; ++l) {
      const Quad unit = packed_vertex(normal[l / kPackedVertices], l % kPackedVertices);
      for (std::size_t c = 0; c < 3; ++c) out[3 * l + c] = unit[c];
    }
  }
}

}  // namespace ORGANSIM_KERNEL_LEVEL
}  // namespace organsim::vertex_kernels
