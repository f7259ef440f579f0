#include "dmap/displacement_map.h"

#include "bind/serialize.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

namespace sd {

namespace osd = OpenSubdiv::Far;

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

/// One CV of the control grid with its weight in an evaluation.
struct Tap {
    int index;
    double weight;
};

/// The control grid of one sweep as an OpenSubdiv patch table: `columns` control points
/// around (periodic, θ), `rows` along (open, t). Evaluation gives the weights of the grid's
/// control points at (θ, t), so fitting is linear least squares.
class GridSurface {
public:
    GridSurface(int columns, int rows) : columns_(columns), rows_(rows) {
        const int faces = columns * (rows - 1);
        std::vector<int> verts_per_face(static_cast<size_t>(faces), 4), indices;
        indices.reserve(4 * static_cast<size_t>(faces));
        for (int j = 0; j + 1 < rows; ++j)
            for (int i = 0; i < columns; ++i) {
                const int i1 = (i + 1) % columns;
                // Corner 0 -> 1 runs along θ (ptex u), corner 0 -> 3 along t (ptex v).
                indices.insert(indices.end(),
                               {j * columns + i, j * columns + i1, (j + 1) * columns + i1, (j + 1) * columns + i});
            }
        osd::TopologyDescriptor desc;
        desc.numVertices = columns * rows;
        desc.numFaces = faces;
        desc.numVertsPerFace = verts_per_face.data();
        desc.vertIndicesPerFace = indices.data();
        OpenSubdiv::Sdc::Options sdc;
        sdc.SetVtxBoundaryInterpolation(OpenSubdiv::Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
        using Factory = osd::TopologyRefinerFactory<osd::TopologyDescriptor>;
        refiner_.reset(Factory::Create(desc, Factory::Options(OpenSubdiv::Sdc::SCHEME_CATMARK, sdc)));
        if (!refiner_) throw std::runtime_error("OpenSubdiv rejected the displacement control grid");
        osd::PatchTableFactory::Options options(0);
        options.SetEndCapType(osd::PatchTableFactory::Options::ENDCAP_BSPLINE_BASIS);
        options.SetPatchPrecision<double>();
        refiner_->RefineAdaptive(options.GetRefineAdaptiveOptions());
        table_.reset(osd::PatchTableFactory::Create(*refiner_, options));
        if (!table_) throw std::runtime_error("OpenSubdiv made no patch table for the displacement grid");
        patch_map_ = std::make_unique<osd::PatchMap>(*table_);
        base_count_ = columns * rows;
        local_ = table_->GetLocalPointStencilTable<double>();
    }

    int columns() const { return columns_; }
    int rows() const { return rows_; }
    int control_count() const { return base_count_; }

    /// Control points and weights of the surface point at (θ, t), t in [0, 1].
    void taps(double theta, double t, std::vector<Tap>& out) const {
        out.clear();
        double c = theta / kTwoPi * columns_;
        c -= std::floor(c / columns_) * columns_;
        int i = static_cast<int>(std::floor(c));
        double u = c - i;
        if (i >= columns_) {  // rounding at 2π
            i = columns_ - 1;
            u = 1.0;
        }
        const double r = std::clamp(t, 0.0, 1.0) * (rows_ - 1);
        const int j = std::min(static_cast<int>(std::floor(r)), rows_ - 2);
        const double v = r - j;
        const osd::PatchTable::PatchHandle* h = patch_map_->FindPatch(j * columns_ + i, u, v);
        if (!h) throw std::runtime_error("OpenSubdiv found no patch for a displacement sample");
        double w[20];
        table_->EvaluateBasis(*h, u, v, w);
        const auto cvs = table_->GetPatchVertices(*h);
        for (int k = 0; k < cvs.size(); ++k) {
            const int index = cvs[k];
            if (w[k] == 0.0) continue;
            if (index < base_count_) {
                out.push_back({index, w[k]});
            } else {  // an end-cap local point: its stencil over the base control points
                const auto s = local_->GetStencil(index - base_count_);
                for (int q = 0; q < s.GetSize(); ++q)
                    out.push_back({s.GetVertexIndices()[q], w[k] * s.GetWeights()[q]});
            }
        }
    }

private:
    int columns_, rows_, base_count_ = 0;
    std::unique_ptr<osd::TopologyRefiner> refiner_;
    std::unique_ptr<osd::PatchTable> table_;
    std::unique_ptr<osd::PatchMap> patch_map_;
    const osd::StencilTableReal<double>* local_ = nullptr;  // owned by table_
};

double wrap_theta(double theta) {
    theta = std::fmod(theta, kTwoPi);
    return theta < 0.0 ? theta + kTwoPi : theta;
}

/// Global sweep parameter t = (span + u) / spans.
double global_t(const Sweep& s, int span, double u) { return (span + u) / s.span_count(); }

/// dC/dt (t global) at the two ends of a sweep: how far one unit of t goes there.
dvec2 end_speeds(const Sweep& s) {
    const SweepGeometry& g = s.rest_geometry;
    const int last = g.span_count() - 1;
    return dvec2(glm::length(g.center_span(0).derivative(0.0)) * g.span_count(),
                 glm::length(g.center_span(last).derivative(1.0)) * g.span_count());
}

/// The map's parameter of a bound point: t inside the sweep; beyond an end plane (binding
/// clamps such points to the end ellipse and keeps their distance from the plane as the
/// local z), t continues past 0 or 1 by z / (dC/dt), so that the caps of a sweep (a
/// shoulder, a hip) get their own part of the map instead of piling onto t = 0 or 1.
double extended_t(const Sweep& s, int span, double u, double z, const dvec2& speeds) {
    const double t = global_t(s, span, u);
    if (span == 0 && u <= 0.0 && z < 0.0 && speeds.x > 0.0) return z / speeds.x;
    if (span == s.span_count() - 1 && u >= 1.0 && z > 0.0 && speeds.y > 0.0) return 1.0 + z / speeds.y;
    return t;
}

/// The longest a sweep's map reaches past either end, in units of t.
constexpr double kMaxExtension = 1.0;

dvec3 ellipse_point(const Sweep& s, double t, double theta) {
    int span;
    double u;
    split_parameter(s.span_count(), t, &span, &u);
    const dvec2 ab = s.rest_half_axes.at(span, u);
    return dvec3(ab.x * std::cos(theta), ab.y * std::sin(theta), 0.0);
}

// ---- closest point on a triangle (Ericson, Real-Time Collision Detection 5.1.5) ----------

dvec3 closest_on_triangle(const dvec3& p, const dvec3& a, const dvec3& b, const dvec3& c, dvec3* bary) {
    const dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) {
        *bary = {1, 0, 0};
        return a;
    }
    const dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) {
        *bary = {0, 1, 0};
        return b;
    }
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        const double v = d1 / (d1 - d3);
        *bary = {1 - v, v, 0};
        return a + v * ab;
    }
    const dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) {
        *bary = {0, 0, 1};
        return c;
    }
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        const double w = d2 / (d2 - d6);
        *bary = {1 - w, 0, w};
        return a + w * ac;
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        *bary = {0, 1 - w, w};
        return b + w * (c - b);
    }
    const double denom = 1.0 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    *bary = {1 - v - w, v, w};
    return a + ab * v + ac * w;
}

}  // namespace

// ---- ClosestPoint --------------------------------------------------------------------------

namespace {

/// The grid cell (0..dims-1) of a coordinate `x` cells from the grid's corner. Clamped in
/// double before the conversion: a query point far outside the grid (|x| beyond int's range,
/// or NaN) would make static_cast<int> undefined (found by fuzz_dmap, issue 15).
int grid_cell(double x, int dims) {
    const double c = std::floor(x);
    if (!(c >= 0.0)) return 0;  // also NaN
    if (!(c <= static_cast<double>(dims - 1))) return dims - 1;
    return static_cast<int>(c);
}

}  // namespace

ClosestPoint::ClosestPoint(std::vector<dvec3> positions, std::vector<int32_t> triangles)
    : positions_(std::move(positions)), triangles_(std::move(triangles)) {
    const size_t T = triangles_.size() / 3;
    if (T == 0) throw InvalidInput("the fitted mesh has no triangles");
    dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const int32_t v : triangles_) {
        lo = glm::min(lo, positions_[static_cast<size_t>(v)]);
        hi = glm::max(hi, positions_[static_cast<size_t>(v)]);
    }
    const dvec3 size = glm::max(hi - lo, dvec3(1e-9));
    // About two triangles per cell on a surface: cells ~ sqrt(area / T).
    double cell = std::cbrt(size.x * size.y * size.z / static_cast<double>(T));
    cell = std::max(cell, std::max({size.x, size.y, size.z}) / 256.0);
    cell_ = cell;
    lo_ = lo;
    for (int k = 0; k < 3; ++k) dims_[k] = std::clamp(static_cast<int>(std::ceil(size[k] / cell)), 1, 256);
    const auto cell_of = [&](const dvec3& p, int k) { return grid_cell((p[k] - lo_[k]) / cell_, dims_[k]); };
    const size_t cells = static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2];
    std::vector<uint32_t> count(cells + 1, 0);
    const auto for_cells = [&](size_t t, auto&& f) {
        dvec3 a = positions_[static_cast<size_t>(triangles_[3 * t])], b = a;
        for (int k = 1; k < 3; ++k) {
            a = glm::min(a, positions_[static_cast<size_t>(triangles_[3 * t + k])]);
            b = glm::max(b, positions_[static_cast<size_t>(triangles_[3 * t + k])]);
        }
        for (int z = cell_of(a, 2); z <= cell_of(b, 2); ++z)
            for (int y = cell_of(a, 1); y <= cell_of(b, 1); ++y)
                for (int x = cell_of(a, 0); x <= cell_of(b, 0); ++x)
                    f((static_cast<size_t>(z) * dims_[1] + y) * dims_[0] + x);
    };
    for (size_t t = 0; t < T; ++t) for_cells(t, [&](size_t c) { ++count[c + 1]; });
    for (size_t c = 0; c < cells; ++c) count[c + 1] += count[c];
    cell_start_ = count;
    cell_items_.resize(count[cells]);
    std::vector<uint32_t> fill(count.begin(), count.end() - 1);
    for (size_t t = 0; t < T; ++t) for_cells(t, [&](size_t c) { cell_items_[fill[c]++] = static_cast<uint32_t>(t); });
}

double ClosestPoint::query(const dvec3& p, int* triangle, dvec3* barycentric) const {
    int home[3];
    dvec3 clamped;
    int max_ring = 0;
    for (int k = 0; k < 3; ++k) {
        clamped[k] = std::clamp(p[k], lo_[k], lo_[k] + dims_[k] * cell_);
        home[k] = grid_cell((p[k] - lo_[k]) / cell_, dims_[k]);
        max_ring = std::max({max_ring, home[k], dims_[k] - 1 - home[k]});
    }
    const double outside2 = glm::dot(p - clamped, p - clamped);
    double best2 = std::numeric_limits<double>::infinity();
    const auto visit = [&](int x, int y, int z) {
        const size_t c = (static_cast<size_t>(z) * dims_[1] + y) * dims_[0] + x;
        for (uint32_t i = cell_start_[c]; i < cell_start_[c + 1]; ++i) {
            const size_t t = cell_items_[i];
            dvec3 bary;
            const dvec3 q = closest_on_triangle(p, positions_[static_cast<size_t>(triangles_[3 * t])],
                                                positions_[static_cast<size_t>(triangles_[3 * t + 1])],
                                                positions_[static_cast<size_t>(triangles_[3 * t + 2])], &bary);
            const double d2 = glm::dot(q - p, q - p);
            if (d2 < best2) {
                best2 = d2;
                *triangle = static_cast<int>(t);
                *barycentric = bary;
            }
        }
    };
    for (int r = 0; r <= max_ring; ++r) {
        // Rings 0..r-1 are searched: stop when nothing outside their cube can be nearer. For p
        // inside the grid that is p's distance to the cube's faces; outside it, every cell of
        // ring r is at least (r - 1) cells from the clamped point.
        double reach;
        if (outside2 == 0.0 && r > 0) {
            reach = std::numeric_limits<double>::infinity();
            for (int k = 0; k < 3; ++k) {
                reach = std::min(reach, p[k] - (lo_[k] + (home[k] - r + 1) * cell_));
                reach = std::min(reach, lo_[k] + (home[k] + r) * cell_ - p[k]);
            }
            reach = std::max(reach, 0.0);
        } else {
            reach = std::max(0, r - 1) * cell_;
        }
        if (r > 0 && best2 <= outside2 + reach * reach) break;
        // The shell of cells at Chebyshev distance r from home, clipped to the grid.
        const int z0 = std::max(0, home[2] - r), z1 = std::min(dims_[2] - 1, home[2] + r);
        const int y0 = std::max(0, home[1] - r), y1 = std::min(dims_[1] - 1, home[1] + r);
        const int x0 = std::max(0, home[0] - r), x1 = std::min(dims_[0] - 1, home[0] + r);
        for (int z = z0; z <= z1; ++z)
            for (int y = y0; y <= y1; ++y) {
                if (std::abs(z - home[2]) == r || std::abs(y - home[1]) == r) {
                    for (int x = x0; x <= x1; ++x) visit(x, y, z);
                } else {
                    if (home[0] - r >= 0) visit(home[0] - r, y, z);
                    if (r > 0 && home[0] + r < dims_[0]) visit(home[0] + r, y, z);
                }
            }
    }
    return std::sqrt(best2);
}

// ---- DisplacementMap -----------------------------------------------------------------------

struct DisplacementMap::Impl {
    uint64_t rig_fingerprint = 0;
    std::vector<std::unique_ptr<GridSurface>> grids;  // #S
    std::vector<std::vector<dvec3>> controls;         // #S, control points of d
    std::vector<DisplacementFitStats> stats;          // #S
    std::vector<dvec2> range;                         // #S, the grid's t range [lo, hi] (extended)
    std::vector<dvec2> speeds;                        // #S, end_speeds
    ClosestPoint closest;
    Binding source;  // the fitted mesh's weights

    /// Grid parameter in [0, 1] of an (extended) t.
    double grid_t(int s, double t) const {
        const dvec2 r = range[static_cast<size_t>(s)];
        return std::clamp((t - r.x) / (r.y - r.x), 0.0, 1.0);
    }
    /// d at (θ, t), t extended (may lie outside [0, 1]).
    dvec3 eval(int s, double theta, double t) const {
        thread_local std::vector<Tap> taps;
        grids[static_cast<size_t>(s)]->taps(wrap_theta(theta), grid_t(s, t), taps);
        dvec3 d(0.0);
        for (const Tap& k : taps) d += k.weight * controls[static_cast<size_t>(s)][static_cast<size_t>(k.index)];
        return d;
    }
};

DisplacementMap::DisplacementMap() : impl_(std::make_unique<Impl>()) {}
DisplacementMap::~DisplacementMap() = default;
DisplacementMap::DisplacementMap(DisplacementMap&&) noexcept = default;
DisplacementMap& DisplacementMap::operator=(DisplacementMap&&) noexcept = default;

DisplacementMap DisplacementMap::fit(const Rig& rig, const Binding& binding, int T, const int32_t* triangles,
                                     const DisplacementMapOptions& o) {
    if (!(o.theta_cells >= 4 && o.theta_cells <= 256)) throw InvalidInput("theta_cells must be in 4..256");
    if (!(o.t_cells_per_span >= 1 && o.t_cells_per_span <= 64)) throw InvalidInput("t_cells_per_span must be in 1..64");
    if (!(o.smoothing >= 0.0 && o.smoothing <= 1e6)) throw InvalidInput("smoothing must be in [0, 1e6]");
    if (T < 1 || T > 100'000'000 || !triangles) throw InvalidInput("the bound mesh's triangles are missing");
    binding.check_structure();
    // Structural, like the Deformer; whether it is the very rig is sd_deformer_create's test
    // (rig fingerprints), and bind() stamps new bindings with this binding's fingerprint.
    binding.check_against(rig);
    const int V = binding.vertex_count();
    for (int i = 0; i < 3 * T; ++i)
        if (triangles[i] < 0 || triangles[i] >= V)
            throw InvalidInput("triangle " + std::to_string(i / 3) + " has a vertex index outside 0.." +
                               std::to_string(V - 1));

    DisplacementMap m;
    Impl& impl = *m.impl_;
    impl.rig_fingerprint = rig_fingerprint(rig);
    impl.source = binding;
    std::vector<dvec3> positions(static_cast<size_t>(V));
    for (int v = 0; v < V; ++v)
        positions[static_cast<size_t>(v)] = dvec3(binding.rest_positions[3 * static_cast<size_t>(v)],
                                                  binding.rest_positions[3 * static_cast<size_t>(v) + 1],
                                                  binding.rest_positions[3 * static_cast<size_t>(v) + 2]);
    impl.closest = ClosestPoint(positions, std::vector<int32_t>(triangles, triangles + 3 * static_cast<size_t>(T)));

    const int S = static_cast<int>(rig.sweeps.size());
    impl.grids.resize(static_cast<size_t>(S));
    impl.controls.resize(static_cast<size_t>(S));
    impl.stats.resize(static_cast<size_t>(S));
    impl.range.assign(static_cast<size_t>(S), dvec2(0.0, 1.0));
    impl.speeds.resize(static_cast<size_t>(S));
    for (int s = 0; s < S; ++s) impl.speeds[static_cast<size_t>(s)] = end_speeds(rig.sweeps[static_cast<size_t>(s)]);
    // Samples per sweep: (θ, t, d, weight).
    struct Sample {
        double theta, t, w;
        dvec3 d;
    };
    std::vector<std::vector<Sample>> samples(static_cast<size_t>(S));
    for (int v = 0; v < V; ++v)
        for (uint32_t i = binding.sweep_offsets[static_cast<size_t>(v)];
             i < binding.sweep_offsets[static_cast<size_t>(v) + 1]; ++i) {
            const SweepInfluence& inf = binding.sweep_influences[i];
            const Sweep& sw = rig.sweeps[static_cast<size_t>(inf.sweep)];
            const double theta = wrap_theta(std::atan2(inf.sin_theta, inf.cos_theta));
            const double t =
                std::clamp(extended_t(sw, inf.span, inf.u, inf.local[2], impl.speeds[static_cast<size_t>(inf.sweep)]),
                           -kMaxExtension, 1.0 + kMaxExtension);
            dvec2& range = impl.range[static_cast<size_t>(inf.sweep)];
            range = dvec2(std::min(range.x, t), std::max(range.y, t));
            const dvec3 local(inf.local[0], inf.local[1], inf.local[2]);
            const dvec2 ab = sw.rest_half_axes.at(inf.span, inf.u);
            const dvec3 d = local - dvec3(ab.x * std::cos(theta), ab.y * std::sin(theta), 0.0);
            samples[static_cast<size_t>(inf.sweep)].push_back(
                {theta, t, static_cast<double>(inf.weight) * inf.weight, d});
        }

    tbb::parallel_for(0, S, [&](int s) {
        const Sweep& sw = rig.sweeps[static_cast<size_t>(s)];
        const dvec2 range = impl.range[static_cast<size_t>(s)];
        const double cell = 1.0 / (sw.span_count() * o.t_cells_per_span);  // in t
        const int columns = o.theta_cells, rows = static_cast<int>(std::ceil((range.y - range.x) / cell - 1e-9)) + 1;
        auto grid = std::make_unique<GridSurface>(columns, rows);
        const int n = grid->control_count();
        const auto& smp = samples[static_cast<size_t>(s)];
        std::vector<dvec3> x(static_cast<size_t>(n), dvec3(0.0));
        DisplacementFitStats st;
        st.samples = static_cast<int>(smp.size());
        st.rows = rows;
        st.columns = columns;
        if (!smp.empty()) {
            // Normal equations: (A^T W A + λ (D^T D) + ε I) x = A^T W b, 3 right-hand sides.
            std::vector<Eigen::Triplet<double>> trip;
            Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n, 3);
            std::vector<Tap> taps;
            double data_trace = 0.0, total_w = 0.0;
            for (const Sample& q : smp) {
                grid->taps(q.theta, impl.grid_t(s, q.t), taps);
                for (const Tap& a : taps) {
                    for (const Tap& b : taps) trip.emplace_back(a.index, b.index, q.w * a.weight * b.weight);
                    for (int k = 0; k < 3; ++k) rhs(a.index, k) += q.w * a.weight * q.d[k];
                    data_trace += q.w * a.weight * a.weight;
                }
                total_w += q.w;
            }
            // Bending of the control grid: second differences around (periodic), along, and
            // mixed, scaled by the data term's mean diagonal.
            const double lambda = o.smoothing * data_trace / n;
            const auto id = [&](int i, int j) { return j * columns + ((i % columns) + columns) % columns; };
            const auto add_row = [&](const std::vector<Tap>& row, double scale) {
                for (const Tap& a : row)
                    for (const Tap& b : row) trip.emplace_back(a.index, b.index, scale * a.weight * b.weight);
            };
            for (int j = 0; j < rows; ++j)
                for (int i = 0; i < columns; ++i) {
                    add_row({{id(i - 1, j), 1.0}, {id(i, j), -2.0}, {id(i + 1, j), 1.0}}, lambda);
                    if (j >= 1 && j + 1 < rows)
                        add_row({{id(i, j - 1), 1.0}, {id(i, j), -2.0}, {id(i, j + 1), 1.0}}, lambda);
                    if (j + 1 < rows)
                        add_row({{id(i, j), 1.0}, {id(i + 1, j), -1.0}, {id(i, j + 1), -1.0}, {id(i + 1, j + 1), 1.0}},
                                2.0 * lambda);
                }
            const double ridge = 1e-9 * (data_trace / n + 1e-30);
            for (int i = 0; i < n; ++i) trip.emplace_back(i, i, ridge);
            Eigen::SparseMatrix<double> ata(n, n);
            ata.setFromTriplets(trip.begin(), trip.end());
            Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(ata);
            if (solver.info() != Eigen::Success) throw std::runtime_error("displacement map: factorisation failed");
            const Eigen::MatrixXd sol = solver.solve(rhs);
            for (int i = 0; i < n; ++i) x[static_cast<size_t>(i)] = dvec3(sol(i, 0), sol(i, 1), sol(i, 2));
            // Residuals at the samples.
            double sum2 = 0.0;
            for (const Sample& q : smp) {
                grid->taps(q.theta, impl.grid_t(s, q.t), taps);
                dvec3 d(0.0);
                for (const Tap& a : taps) d += a.weight * x[static_cast<size_t>(a.index)];
                const double e = glm::length(d - q.d);
                sum2 += q.w * e * e;
                st.max = std::max(st.max, e);
            }
            st.rms = total_w > 0.0 ? std::sqrt(sum2 / total_w) : 0.0;
        }
        impl.grids[static_cast<size_t>(s)] = std::move(grid);
        impl.controls[static_cast<size_t>(s)] = std::move(x);
        impl.stats[static_cast<size_t>(s)] = st;
    });
    return m;
}

int DisplacementMap::sweep_count() const { return static_cast<int>(impl_->grids.size()); }

const DisplacementFitStats& DisplacementMap::stats(int sweep) const {
    if (sweep < 0 || sweep >= sweep_count()) throw InvalidInput("sweep index out of range");
    return impl_->stats[static_cast<size_t>(sweep)];
}

dvec3 DisplacementMap::displacement(int sweep, double theta, double t) const {
    if (sweep < 0 || sweep >= sweep_count()) throw InvalidInput("sweep index out of range");
    if (!std::isfinite(theta) || !std::isfinite(t)) throw InvalidInput("theta and t must be finite");
    return impl_->eval(sweep, theta, t);
}

dvec3 DisplacementMap::local(const Rig& rig, int sweep, double theta, double t) const {
    const dvec3 d = displacement(sweep, theta, t);
    return ellipse_point(rig.sweeps.at(static_cast<size_t>(sweep)), std::clamp(t, 0.0, 1.0), theta) + d;
}

dvec3 DisplacementMap::rest_point(const Rig& rig, int sweep, double theta, double t) const {
    const Sweep& s = rig.sweeps.at(static_cast<size_t>(sweep));
    int span;
    double u;
    split_parameter(s.span_count(), t, &span, &u);
    return s.rest_geometry.center(span, u) + s.rest_geometry.rotation(span, u) * local(rig, sweep, theta, t);
}

void DisplacementMap::transfer_weights(int count, const float* positions, int* sweep_slots,
                                       std::vector<int32_t>& sweep_ids, std::vector<float>& sweep_weights,
                                       int* bone_slots, std::vector<int32_t>& bone_ids,
                                       std::vector<float>& bone_weights) const {
    if (count < 1 || count > 50'000'000 || !positions) throw InvalidInput("point count must be in 1..5e7");
    const Impl& impl = *impl_;
    const Binding& src = impl.source;
    const auto& tris = impl.closest.triangles();
    using Row = std::vector<std::pair<int32_t, float>>;
    std::vector<Row> sweeps(static_cast<size_t>(count)), bones(static_cast<size_t>(count));
    tbb::parallel_for(0, count, [&](int p) {
        const dvec3 x(positions[3 * static_cast<size_t>(p)], positions[3 * static_cast<size_t>(p) + 1],
                      positions[3 * static_cast<size_t>(p) + 2]);
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z)) return;
        int t = 0;
        dvec3 bary(1, 0, 0);
        impl.closest.query(x, &t, &bary);
        std::map<int32_t, double> ws, wb;
        for (int k = 0; k < 3; ++k) {
            const auto v = static_cast<size_t>(tris[3 * static_cast<size_t>(t) + k]);
            for (uint32_t i = src.sweep_offsets[v]; i < src.sweep_offsets[v + 1]; ++i)
                ws[src.sweep_influences[i].sweep] += bary[k] * src.sweep_influences[i].weight;
            for (uint32_t i = src.bone_offsets[v]; i < src.bone_offsets[v + 1]; ++i)
                wb[src.bone_influences[i].bone] += bary[k] * src.bone_influences[i].weight;
        }
        for (const auto& [id, w] : ws)
            if (w > 1e-7) sweeps[static_cast<size_t>(p)].emplace_back(id, static_cast<float>(w));
        for (const auto& [id, w] : wb)
            if (w > 1e-7) bones[static_cast<size_t>(p)].emplace_back(id, static_cast<float>(w));
    });
    for (int p = 0; p < count; ++p)
        if (sweeps[static_cast<size_t>(p)].empty() && bones[static_cast<size_t>(p)].empty())
            throw InvalidInput("point " + std::to_string(p) + " has a non-finite coordinate");
    size_t S = 0, K = 0;
    for (int p = 0; p < count; ++p) {
        S = std::max(S, sweeps[static_cast<size_t>(p)].size());
        K = std::max(K, bones[static_cast<size_t>(p)].size());
    }
    *sweep_slots = static_cast<int>(S);
    *bone_slots = static_cast<int>(K);
    sweep_ids.assign(S * static_cast<size_t>(count), -1);
    sweep_weights.assign(S * static_cast<size_t>(count), 0.0f);
    bone_ids.assign(K * static_cast<size_t>(count), -1);
    bone_weights.assign(K * static_cast<size_t>(count), 0.0f);
    for (size_t p = 0; p < static_cast<size_t>(count); ++p) {
        for (size_t i = 0; i < sweeps[p].size(); ++i) {
            sweep_ids[p * S + i] = sweeps[p][i].first;
            sweep_weights[p * S + i] = sweeps[p][i].second;
        }
        for (size_t i = 0; i < bones[p].size(); ++i) {
            bone_ids[p * K + i] = bones[p][i].first;
            bone_weights[p * K + i] = bones[p][i].second;
        }
    }
}

Binding DisplacementMap::bind(const Rig& rig, int count, const float* positions, double snap, int* snapped,
                              int* influences) const {
    if (rig_fingerprint(rig) != impl_->rig_fingerprint)
        throw InvalidInput("the rig is not the one the displacement map was fitted with");
    if (!(snap >= 0.0)) throw InvalidInput("snap must be >= 0");
    int S = 0, K = 0;
    std::vector<int32_t> sid, bid;
    std::vector<float> sw, bw;
    transfer_weights(count, positions, &S, sid, sw, &K, bid, bw);
    Binding b = bind_vertices(rig, count, positions, S, sid.data(), sw.data(), K, bid.data(), bw.data(),
                              /*weights_handed_over=*/true);
    // The new binding fits whatever rig the fitted binding fits (its fingerprint), so it can
    // replace it with the caller's own rig handle.
    b.rig_fingerprint = impl_->source.rig_fingerprint;
    std::vector<uint8_t> took(b.sweep_influences.size(), 0);
    if (snap > 0.0) {
        tbb::parallel_for(size_t(0), b.sweep_influences.size(), [&](size_t i) {
            SweepInfluence& inf = b.sweep_influences[i];
            const Sweep& s = rig.sweeps[static_cast<size_t>(inf.sweep)];
            const double theta = std::atan2(inf.sin_theta, inf.cos_theta);
            const double t =
                extended_t(s, inf.span, inf.u, inf.local[2], impl_->speeds[static_cast<size_t>(inf.sweep)]);
            const dvec2 ab = s.rest_half_axes.at(inf.span, inf.u);
            const dvec3 l =
                dvec3(ab.x * std::cos(theta), ab.y * std::sin(theta), 0.0) + impl_->eval(inf.sweep, theta, t);
            const dvec3 own(inf.local[0], inf.local[1], inf.local[2]);
            if (glm::length(l - own) > snap * std::min(ab.x, ab.y)) return;
            for (int k = 0; k < 3; ++k) inf.local[k] = static_cast<float>(l[k]);
            took[i] = 1;
        });
    }
    if (snapped) *snapped = static_cast<int>(std::count(took.begin(), took.end(), uint8_t(1)));
    if (influences) *influences = static_cast<int>(took.size());
    return b;
}

}  // namespace sd
