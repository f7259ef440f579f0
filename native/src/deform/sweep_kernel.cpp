#include "deform/sweep_kernel.h"

#include "deform/frame_blend.h"
#include "math/flush_denormals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <type_traits>

namespace sd {

namespace {
constexpr int32_t kBatch = 2048;

/// w (C(u) + R(u) l) for influences [begin, end) of one half-span. Written as one flat loop
/// over arrays with loop-invariant coefficients, no branches: it vectorises.
void evaluate_batch(const HalfSpanKernel& k, int32_t begin, int32_t end, const float* __restrict u_,
                    const float* __restrict w_, const float* __restrict x_, const float* __restrict y_,
                    const float* __restrict z_, const float* __restrict cos_, const float* __restrict sin_,
                    float* __restrict p4) {
    const HalfSpanKernel c = k;  // locals: no aliasing with the outputs
    for (int32_t i = begin; i < end; ++i) {
        const float u = u_[i];
        const float da = c.da[0] + u * (c.da[1] + u * c.da[2]);
        const float db = c.db[0] + u * (c.db[1] + u * c.db[2]);
        const float lx = x_[i] + da * cos_[i], ly = y_[i] + db * sin_[i], lz = z_[i];
        // R(u) l with Q(u) = (1-u) q0 + u q1 unnormalised: l + s (w (q×l) + q×(q×l)), s = 2/|q|².
        const float qx = c.q0[0] + u * (c.q1[0] - c.q0[0]);
        const float qy = c.q0[1] + u * (c.q1[1] - c.q0[1]);
        const float qz = c.q0[2] + u * (c.q1[2] - c.q0[2]);
        const float qw = c.q0[3] + u * (c.q1[3] - c.q0[3]);
        const float s = 2.0f / (qx * qx + qy * qy + qz * qz + qw * qw);
        const float cx = qy * lz - qz * ly, cy = qz * lx - qx * lz, cz = qx * ly - qy * lx;
        const float ex = qy * cz - qz * cy, ey = qz * cx - qx * cz, ez = qx * cy - qy * cx;
        const float w = w_[i];
        float* o = p4 + 4 * static_cast<size_t>(i);
        o[0] = w * (c.c[0][0] + u * (c.c[1][0] + u * (c.c[2][0] + u * c.c[3][0])) + lx + s * (qw * cx + ex));
        o[1] = w * (c.c[0][1] + u * (c.c[1][1] + u * (c.c[2][1] + u * c.c[3][1])) + ly + s * (qw * cy + ey));
        o[2] = w * (c.c[0][2] + u * (c.c[1][2] + u * (c.c[2][2] + u * c.c[3][2])) + lz + s * (qw * cz + ez));
        o[3] = 0.0f;
    }
}

/// Influences of frame-blended vertices: the weighted position w (C(u) + R(u) l), and the
/// influence as a weighted dual quaternion about the vertex (frame_blend.h): w q and
/// ½ w (p - V) q, with q = R(u) R_rest(u)^-1 as a unit quaternion. Flat and branch-free like
/// evaluate_batch, so it vectorises too (sqrt without errno: -fno-math-errno).
struct FrameSlots {
    const float* __restrict u, * __restrict w, * __restrict x, * __restrict y, * __restrict z, * __restrict cos, * __restrict sin, * __restrict rx, * __restrict ry, * __restrict rz, * __restrict rw, * __restrict vx, * __restrict vy, * __restrict vz;
    float* __restrict p4;      // 4 per slot: w p, 0 (one load per slot in the vertices' pass)
    float* __restrict frames;  // 8 per slot: w q, then ½ w (p - V) q (one cache line per slot)
};

void evaluate_frame_batch(const HalfSpanKernel& k, int32_t begin, int32_t end, const FrameSlots& f) {
    const HalfSpanKernel c = k;  // locals: no aliasing with the outputs
    // No slot's outputs alias another's inputs (ivdep): without it GCC kept the loop scalar
    // behind a runtime alias check over 25 arrays.
    SD_NO_ALIASING
    for (int32_t i = begin; i < end; ++i) {
        const float u = f.u[i];
        const float da = c.da[0] + u * (c.da[1] + u * c.da[2]);
        const float db = c.db[0] + u * (c.db[1] + u * c.db[2]);
        const float lx = f.x[i] + da * f.cos[i], ly = f.y[i] + db * f.sin[i], lz = f.z[i];
        const float ax = c.q0[0] + u * (c.q1[0] - c.q0[0]);
        const float ay = c.q0[1] + u * (c.q1[1] - c.q0[1]);
        const float az = c.q0[2] + u * (c.q1[2] - c.q0[2]);
        const float aw = c.q0[3] + u * (c.q1[3] - c.q0[3]);
        const float n2 = ax * ax + ay * ay + az * az + aw * aw;
        const float s = 2.0f / n2, inv = 1.0f / std::sqrt(n2);
        const float cx = ay * lz - az * ly, cy = az * lx - ax * lz, cz = ax * ly - ay * lx;
        const float ex = ay * cz - az * cy, ey = az * cx - ax * cz, ez = ax * cy - ay * cx;
        const float pxv = c.c[0][0] + u * (c.c[1][0] + u * (c.c[2][0] + u * c.c[3][0])) + lx + s * (aw * cx + ex);
        const float pyv = c.c[0][1] + u * (c.c[1][1] + u * (c.c[2][1] + u * c.c[3][1])) + ly + s * (aw * cy + ey);
        const float pzv = c.c[0][2] + u * (c.c[1][2] + u * (c.c[2][2] + u * c.c[3][2])) + lz + s * (aw * cz + ez);
        // w q, q = Q(u)/|Q(u)| r, r = Q_rest(u)^-1
        const float w = f.w[i], wn = w * inv;
        const float rx = f.rx[i], ry = f.ry[i], rz = f.rz[i], rw = f.rw[i];
        const float qx = wn * (aw * rx + ax * rw + ay * rz - az * ry);
        const float qy = wn * (aw * ry - ax * rz + ay * rw + az * rx);
        const float qz = wn * (aw * rz + ax * ry - ay * rx + az * rw);
        const float qw = wn * (aw * rw - ax * rx - ay * ry - az * rz);
        // ½ (t, 0) (w q), t = p - V
        const float tx = 0.5f * (pxv - f.vx[i]), ty = 0.5f * (pyv - f.vy[i]), tz = 0.5f * (pzv - f.vz[i]);
        float* o = f.frames + 8 * static_cast<size_t>(i);
        o[0] = qx;
        o[1] = qy;
        o[2] = qz;
        o[3] = qw;
        o[4] = tx * qw + ty * qz - tz * qy;
        o[5] = -tx * qz + ty * qw + tz * qx;
        o[6] = tx * qy - ty * qx + tz * qw;
        o[7] = -(tx * qx + ty * qy + tz * qz);
        float* p = f.p4 + 4 * static_cast<size_t>(i);
        p[0] = w * pxv;
        p[1] = w * pyv;
        p[2] = w * pzv;
        p[3] = 0.0f;
    }
}

/// With J: w R(u) R_rest(u)^-1 of slots [begin, end) as 9 floats each (row-major), with
/// Q(u) = (1-u) q0 + u q1 normalised as in the position. Flat and branch-free: it vectorises.
void evaluate_turn_batch(const HalfSpanKernel& k, int32_t begin, int32_t end, const float* __restrict u_,
                         const float* __restrict w_, const float* __restrict rx_, const float* __restrict ry_,
                         const float* __restrict rz_, const float* __restrict rw_, float* __restrict turns) {
    const HalfSpanKernel c = k;
    SD_NO_ALIASING
    for (int32_t i = begin; i < end; ++i) {
        const float u = u_[i];
        const float ax = c.q0[0] + u * (c.q1[0] - c.q0[0]);
        const float ay = c.q0[1] + u * (c.q1[1] - c.q0[1]);
        const float az = c.q0[2] + u * (c.q1[2] - c.q0[2]);
        const float aw = c.q0[3] + u * (c.q1[3] - c.q0[3]);
        const float rx = rx_[i], ry = ry_[i], rz = rz_[i], rw = rw_[i];
        // q = Q(u) r, unnormalised; R(q) = R(Q/|Q|) r is R(q) / |Q|², so w / |Q|² weighs it.
        const float x = aw * rx + ax * rw + ay * rz - az * ry;
        const float y = aw * ry - ax * rz + ay * rw + az * rx;
        const float z = aw * rz + ax * ry - ay * rx + az * rw;
        const float w = aw * rw - ax * rx - ay * ry - az * rz;
        const float n2 = ax * ax + ay * ay + az * az + aw * aw;  // = |q|², r being a unit quaternion
        const float s = w_[i] / n2, s2 = 2.0f * s;
        float* o = turns + 9 * static_cast<size_t>(i);
        o[0] = s * (w * w + x * x - y * y - z * z);
        o[1] = s2 * (x * y - w * z);
        o[2] = s2 * (x * z + w * y);
        o[3] = s2 * (x * y + w * z);
        o[4] = s * (w * w - x * x + y * y - z * z);
        o[5] = s2 * (y * z - w * x);
        o[6] = s2 * (x * z - w * y);
        o[7] = s2 * (y * z + w * x);
        o[8] = s * (w * w - x * x - y * y + z * z);
    }
}

/// j += the unit rotation q as a matrix, weighted by k.
void add_rotation(float k, const float* q, float* j) {
    const float x = q[0], y = q[1], z = q[2], w = q[3];
    j[0] += k * (1 - 2 * (y * y + z * z));
    j[1] += k * 2 * (x * y - w * z);
    j[2] += k * 2 * (x * z + w * y);
    j[3] += k * 2 * (x * y + w * z);
    j[4] += k * (1 - 2 * (x * x + z * z));
    j[5] += k * 2 * (y * z - w * x);
    j[6] += k * 2 * (x * z - w * y);
    j[7] += k * 2 * (y * z + w * x);
    j[8] += k * (1 - 2 * (x * x + y * y));
}

void add_slot_turn(float part, const float* t, float* j) {
    for (int k = 0; k < 9; ++k) j[k] += part * t[k];
}

void add_bone_turn(float w, const Affine3x4& m, float* j) {
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) j[3 * r + c] += w * m.m[r][c];
}

}  // namespace

SweepKernel::SweepKernel(const Binding& b, const std::vector<int>& span_base,
                         const std::vector<std::array<float, 4>>& rest_inverse) {
    const auto& inf = b.sweep_influences;
    const size_t n = inf.size();
    const int V = b.vertex_count();
    std::vector<float> row_blends(V, 0.0f);  // per vertex: its frame share (0: not blended)
    std::vector<uint8_t> blended(n, 0);
    for (int v = 0; v < V; ++v) {
        // Blended as frames: a vertex with a sweep influence and two or more influences; its
        // frame share is their weight.
        int frames = 0;
        float share = 0.0f;
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) ++frames, share += inf[i].weight;
        for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
            ++frames, share += b.bone_influences[i].weight;
        const bool blends = frames > 1 && b.sweep_offsets[v + 1] > b.sweep_offsets[v];
        row_blends[v] = blends ? share : 0.0f;
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) blended[i] = blends;
    }
    // Sorted by (block of vertices, blended as frames, half-span): each batch is one kind and
    // one half-span, with its coefficients held constant, so both kinds of batch vectorise;
    // and a block's influences are evaluated by the task that then sums its vertices, so the
    // slots it reads are the ones it just wrote (in its own core's cache: when the other
    // thread wrote them, a frame on two threads took 0.47 ms instead of 0.32 at times).
    std::vector<int32_t> vertex_of(n);
    for (int v = 0; v < V; ++v)
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) vertex_of[i] = v;
    std::vector<int32_t> half(n);
    for (size_t i = 0; i < n; ++i) half[i] = 2 * (span_base[inf[i].sweep] + inf[i].span) + (inf[i].u < 0.5f ? 0 : 1);
    const auto block_of = [&](uint32_t i) { return vertex_of[i] / kVertexBlock; };
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t c) -> bool {
        if (block_of(a) != block_of(c)) return block_of(a) < block_of(c);
        return blended[a] != blended[c] ? blended[c] != 0 : half[a] < half[c];
    });

    std::vector<uint32_t> slot_of(n);
    planes_.resize(std::vector<size_t>(kSlotPlanes, n));
    slot_vertex_.resize(n);
    for (size_t s = 0; s < n; ++s) {
        const SweepInfluence& f = inf[order[s]];
        slot_of[order[s]] = static_cast<uint32_t>(s);
        planes_[kU][s] = f.u;
        planes_[kW][s] = f.weight;
        planes_[kX][s] = f.local[0];
        planes_[kY][s] = f.local[1];
        planes_[kZ][s] = f.local[2];
        planes_[kCos][s] = f.cos_theta;
        planes_[kSin][s] = f.sin_theta;
        const int vert = vertex_of[order[s]];
        slot_vertex_[s] = vert;
        planes_[kVx][s] = b.rest_positions[3 * static_cast<size_t>(vert)];
        planes_[kVy][s] = b.rest_positions[3 * static_cast<size_t>(vert) + 1];
        planes_[kVz][s] = b.rest_positions[3 * static_cast<size_t>(vert) + 2];
        const auto& r = rest_inverse[order[s]];
        planes_[kRx][s] = r[0];
        planes_[kRy][s] = r[1];
        planes_[kRz][s] = r[2];
        planes_[kRw][s] = r[3];
    }
    for (size_t s = 0; s < n;) {
        const int32_t h = half[order[s]], block = block_of(order[s]);
        const bool frames = blended[order[s]];
        size_t e = s;
        while (e < n && block_of(order[e]) == block && blended[order[e]] == frames && half[order[e]] == h &&
               e - s < static_cast<size_t>(kBatch))
            ++e;
        batches_.push_back({h, static_cast<int32_t>(s), static_cast<int32_t>(e), frames});
        s = e;
    }
    row_offsets_ = b.sweep_offsets;
    rows_.resize(n);
    for (size_t i = 0; i < n; ++i) rows_[i] = slot_of[i];
    for (const BoneInfluence& in : b.bone_influences) bone_count_ = std::max(bone_count_, in.bone + 1);
    // Two lists of vertices, so neither loop branches on the kind: a blended vertex's
    // influences as one run of entries, its sweeps' slots first, then its bones.
    for (int v = 0; v < V; ++v) {
        if (!(row_blends[v] > 0.0f)) {
            plain_vertices_.push_back(v);
            continue;
        }
        BlendedVertex row{v, static_cast<uint32_t>(blend_entries_.size()), row_blends[v], {0, 0}};
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i, ++row.count[0])
            blend_entries_.push_back({slot_of[i], 1.0f});  // (its weight is in the slot)
        for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i, ++row.count[1])
            blend_entries_.push_back({static_cast<uint32_t>(b.bone_influences[i].bone), b.bone_influences[i].weight});
        blended_vertices_.push_back(row);
    }
    // Blocks of kVertexBlock vertices: where each starts in both lists and in the batches.
    for (int first = 0;; first += kVertexBlock) {
        const auto batch_at = std::partition_point(batches_.begin(), batches_.end(),
                                                   [&](const Batch& bt) { return slot_vertex_[bt.begin] < first; });
        block_batches_.push_back(static_cast<int32_t>(batch_at - batches_.begin()));
        const auto plain_at = std::lower_bound(plain_vertices_.begin(), plain_vertices_.end(), first);
        const auto blended_at = std::lower_bound(blended_vertices_.begin(), blended_vertices_.end(), first,
                                                 [](const BlendedVertex& a, int v) { return a.vertex < v; });
        block_plain_.push_back(static_cast<int32_t>(plain_at - plain_vertices_.begin()));
        block_slots_.push_back(batch_at == batches_.end() ? static_cast<int32_t>(n) : batch_at->begin);
        block_blended_.push_back(static_cast<int32_t>(blended_at - blended_vertices_.begin()));
        if (first >= V) break;
    }
    const size_t count = blended_vertices_.size();
    blend_planes_.assign(kBlendPlanes * count, 0.0f);
    for (size_t k = 0; k < count; ++k) {
        for (int c = 0; c < 3; ++c)
            blend_planes_[(rest_x + c) * count + k] =
                b.rest_positions[3 * static_cast<size_t>(blended_vertices_[k].vertex) + c];
        blend_planes_[share_plane * count + k] = blended_vertices_[k].share;
    }
}

void SweepKernel::run(const HalfSpanKernel* half_spans, const Affine3x4* bones, const BoneFrame* bone_frames,
                      const Binding& b, float* out, const LocalMaps& maps) {
    float* const jacobians = maps.jacobians;
    // J is assembled whenever it is asked for, written or applied to a displacement.
    const bool with_j = maps.jacobians != nullptr || maps.moved_count > 0;
    if (with_j) turns_.resize(9 * planes_.size(kU));
    // With displacements, J only for the displaced vertices (a face's shape keys move a few
    // thousand vertices of a body): per vertex, and per batch of influences for the turns.
    // moved_at_ (all -1 between calls) says which displacement a vertex has.
    if (moved_at_.size() != static_cast<size_t>(b.vertex_count())) moved_at_.assign(b.vertex_count(), -1);
    for (int32_t i = 0; i < maps.moved_count; ++i) moved_at_[maps.moved[i]] = i;
    struct Reset {  // back to -1, also if a task throws
        std::vector<int32_t>& at;
        const LocalMaps& maps;
        ~Reset() {
            for (int32_t i = 0; i < maps.moved_count; ++i) at[maps.moved[i]] = -1;
        }
    } reset{moved_at_, maps};
    const int32_t* const moved_at = moved_at_.data();
    const bool any_moved = maps.moved_count > 0;  // (else no vertex's moved_at is looked up)
    const auto needs_j = [&](int v) { return jacobians != nullptr || (any_moved && moved_at[v] >= 0); };
    // The runs of slots of displaced vertices in each batch of plain vertices, where alone J's turns are
    // evaluated (a key on the head displaces a third of the vertices of the blocks it
    // touches), found again only when the set changes: a held shape key displaces the same
    // vertices frame after frame, and looking through every influence for them took a tenth
    // of a displaced frame.
    if (any_moved && !(moved_seen_.size() == static_cast<size_t>(maps.moved_count) &&
                       std::equal(moved_seen_.begin(), moved_seen_.end(), maps.moved))) {
        moved_seen_.clear();  // (found for no set until the runs are complete, should one throw)
        batch_runs_.assign(batches_.size() + 1, 0);
        moved_runs_.clear();
        for (size_t i = 0; i < batches_.size(); ++i) {
            for (int32_t s = batches_[i].begin; s < batches_[i].end && !batches_[i].frames;) {
                if (moved_at[slot_vertex_[s]] < 0) {
                    ++s;
                    continue;
                }
                int32_t e = s + 1;
                while (e < batches_[i].end && moved_at[slot_vertex_[e]] >= 0) ++e;
                moved_runs_.push_back({s, e});
                s = e;
            }
            batch_runs_[i + 1] = static_cast<int32_t>(moved_runs_.size());
        }
        moved_seen_.assign(maps.moved, maps.moved + maps.moved_count);
    }
    const size_t block = 3 * static_cast<size_t>(b.vertex_count());
    SlotPlanes& pl = planes_;
    // (the outputs, p4 and frames, are per task: below)
    const FrameSlots slots{pl[kU],  pl[kW],  pl[kX],  pl[kY],  pl[kZ],  pl[kCos], pl[kSin], pl[kRx],
                           pl[kRy], pl[kRz], pl[kRw], pl[kVx], pl[kVy], pl[kVz],  nullptr,  nullptr};
    // A block's influences (its batches), evaluated by the task that sums its vertices below,
    // into that task's scratch (`at`: the planes from the block's first slot on).
    const auto batches = [&](const int vertex_block, const FrameSlots& at, const int32_t first) {
        for (int32_t i = block_batches_[vertex_block]; i != block_batches_[vertex_block + 1]; ++i) {
            const Batch& bt = batches_[i];
            // A blended vertex's J is its blended frame's turn: its slots' turns are evaluated
            // only where its frames cancel (turn_of, below).
            if (bt.frames) {
                evaluate_frame_batch(half_spans[bt.half_span], bt.begin - first, bt.end - first, at);
                continue;
            }
            evaluate_batch(half_spans[bt.half_span], bt.begin - first, bt.end - first, at.u, at.w, at.x, at.y, at.z,
                           at.cos, at.sin, at.p4);
            if (jacobians != nullptr)
                evaluate_turn_batch(half_spans[bt.half_span], bt.begin, bt.end, slots.u, slots.w, slots.rx, slots.ry,
                                    slots.rz, slots.rw, turns_.data());
            else if (any_moved)
                for (int32_t k = batch_runs_[i]; k != batch_runs_[i + 1]; ++k)
                    evaluate_turn_batch(half_spans[bt.half_span], moved_runs_[k].first, moved_runs_[k].second, slots.u,
                                        slots.w, slots.rx, slots.ry, slots.rz, slots.rw, turns_.data());
        }
    };
    const float* rest = b.rest_positions.data();
    const auto store = [&](int v, Float4 p, const float* j) {
        if (const int32_t i = any_moved ? moved_at[v] : -1; i >= 0) {  // J d
            const float* d = maps.displacements + 3 * static_cast<size_t>(i);
            float* t = maps.turned + 3 * static_cast<size_t>(i);
            for (int row = 0; row < 3; ++row)
                t[row] = j[3 * row] * d[0] + j[3 * row + 1] * d[1] + j[3 * row + 2] * d[2];
        }
        if (jacobians)
            for (int row = 0; row < 3; ++row)
                for (int c = 0; c < 3; ++c)
                    jacobians[static_cast<size_t>(row) * block + 3 * static_cast<size_t>(v) + c] = j[3 * row + c];
        out[3 * v] = p[0];
        out[3 * v + 1] = p[1];
        out[3 * v + 2] = p[2];
    };
    // The bones as columns: a blended matrix then applies with no horizontal sums.
    bone_columns_.resize(4 * static_cast<size_t>(bone_count_));
    for (int bone = 0; bone < bone_count_; ++bone)
        for (int c = 0; c < 4; ++c)
            bone_columns_[4 * static_cast<size_t>(bone) + c] =
                Float4{bones[bone].m[0][c], bones[bone].m[1][c], bones[bone].m[2][c], 0.0f};
    const Float4* columns = bone_columns_.data();
    // One body, compiled twice: with J, and without (sd_deform, every plain frame), where a
    // vertex costs its position alone, none of J's per-vertex lookups and sums (sweep_bench,
    // MakeHuman 80K, alternating builds: 1.07-1.13 -> 0.96-1.04 of linear blend skinning on two
    // threads, 1.02-1.04 -> 0.93-0.98 on one; docs/figures.md).
    const auto plain_vertices = [&](const int k0, const int k1, auto j_wanted, const float* p4,
                                    const int32_t first_slot) {
        constexpr bool kJ = decltype(j_wanted)::value;
        for (int k = k0; k != k1; ++k) {
            const int v = plain_vertices_[k];
            const bool vertex_j = kJ && needs_j(v);
            Float4 p = {0.0f, 0.0f, 0.0f, 0.0f};
            float j[9] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};  // J, row-major
            for (uint32_t i = row_offsets_[v]; i < row_offsets_[v + 1]; ++i) {
                const uint32_t s = rows_[i];
                p += load4(p4 + 4 * static_cast<size_t>(s - first_slot));
                if constexpr (kJ)
                    if (vertex_j) add_slot_turn(1.0f, &turns_[9 * static_cast<size_t>(s)], j);
            }
            // The bones' matrices blended first, then applied once (as linear blend skinning
            // does): four 4-wide multiply-adds per bone; its 3x3 part is J's.
            const uint32_t first = b.bone_offsets[v], last = b.bone_offsets[v + 1];
            if (first != last) {
                Float4 c0 = {0.0f, 0.0f, 0.0f, 0.0f}, c1 = c0, c2 = c0, c3 = c0;
                for (uint32_t i = first; i < last; ++i) {
                    const float w = b.bone_influences[i].weight;
                    const Float4* c = &columns[4 * static_cast<size_t>(b.bone_influences[i].bone)];
                    c0 += w * c[0];
                    c1 += w * c[1];
                    c2 += w * c[2];
                    c3 += w * c[3];
                }
                const float* x = rest + 3 * static_cast<size_t>(v);
                p += c0 * x[0] + c1 * x[1] + c2 * x[2] + c3;
                if constexpr (kJ)
                    if (vertex_j) {
                        const Float4 cols[3] = {c0, c1, c2};
                        for (int row = 0; row < 3; ++row)
                            for (int c = 0; c < 3; ++c) j[3 * row + c] += cols[c][row];
                    }
            }
            if constexpr (kJ) {
                store(v, p, j);
            } else {
                out[3 * v] = p[0];
                out[3 * v + 1] = p[1];
                out[3 * v + 2] = p[2];
            }
        }
    };
    const auto plain_block = [&](const int k0, const int k1, const float* p4, const int32_t first) {
        if (!with_j) {
            plain_vertices(k0, k1, std::false_type{}, p4, first);
        } else if (jacobians) {
            plain_vertices(k0, k1, std::true_type{}, p4, first);
        } else {  // J for the displaced vertices alone: the others as a plain frame's, run by run
            for (int k = k0; k != k1;) {
                const bool moved = moved_at[plain_vertices_[k]] >= 0;
                int end = k + 1;
                while (end != k1 && (moved_at[plain_vertices_[end]] >= 0) == moved) ++end;
                if (moved)
                    plain_vertices(k, end, std::true_type{}, p4, first);
                else
                    plain_vertices(k, end, std::false_type{}, p4, first);
                k = end;
            }
        }
    };
    const int blended_count = static_cast<int>(blended_vertices_.size());
    const size_t count = static_cast<size_t>(blended_count);
    if (with_j) blend_turns_.resize(9 * count);
    float* plane = blend_planes_.data();
    const auto in = [&](int field) { return plane + static_cast<size_t>(field) * count; };
    const BlendedFrames planes{{in(real_x), in(real_x + 1), in(real_x + 2), in(real_x + 3)},
                               {in(dual_x), in(dual_x + 1), in(dual_x + 2), in(dual_x + 3)},
                               {in(rest_x), in(rest_x + 1), in(rest_x + 2)},
                               in(share_plane),
                               {in(position_x), in(position_x + 1), in(position_x + 2)},
                               in(norm2_plane),
                               {in(turn_x), in(turn_x + 1), in(turn_x + 2), in(turn_x + 3)}};
    // The turn of a blended vertex's slot `s`, evaluated on demand (into turns_, whose slot s
    // only the task of s's block touches).
    const auto turn_of = [&](const uint32_t s) {
        const auto bt = std::partition_point(batches_.begin(), batches_.end(),
                                             [&](const Batch& x) { return x.end <= static_cast<int32_t>(s); });
        evaluate_turn_batch(half_spans[bt->half_span], static_cast<int32_t>(s), static_cast<int32_t>(s) + 1, slots.u,
                            slots.w, slots.rx, slots.ry, slots.rz, slots.rw, turns_.data());
        return &turns_[9 * static_cast<size_t>(s)];
    };
    const auto blended_block = [&](const int k0, const int k1, const FrameSlots& at, const int32_t block_first) {
        // 1. Each vertex's frames summed (FrameBlend), into planes.
        for (int k = k0; k != k1; ++k) {
            const BlendedVertex& row = blended_vertices_[k];
            const float* x = rest + 3 * static_cast<size_t>(row.vertex);
            const BlendEntry* const first_slot = blend_entries_.data() + row.first;
            const BlendEntry* const bones_first = first_slot + row.count[0];
            const BlendEntry* const end = bones_first + row.count[1];
            float* j = needs_j(row.vertex) ? &blend_turns_[9 * static_cast<size_t>(k)] : nullptr;
            if (j)
                for (int c = 0; c < 9; ++c) j[c] = 0.0f;
            FrameBlend blend;
            for (const BlendEntry* f = first_slot; f != bones_first; ++f) {
                const float* o = &at.frames[8 * static_cast<size_t>(f->index - block_first)];
                blend.add_weighted(load4(o), load4(o + 4));  // w q, ½ w t q
            }
            for (const BlendEntry* f = bones_first; f != end; ++f) {
                const BoneFrame& bf = bone_frames[f->index];
                if (bf.rigid) {
                    blend.add_bone(f->weight, bf, x);
                } else {
                    float to[3] = {0.0f, 0.0f, 0.0f};
                    bones[f->index].apply_add(1.0f, x, to);
                    const float t[3] = {to[0] - x[0], to[1] - x[1], to[2] - x[2]};
                    blend.add(f->weight, bf.q, t);
                }
            }
            const Float4 real = blend.real(), dual = blend.dual();
            for (int c = 0; c < 4; ++c) {
                plane[(real_x + c) * count + k] = real[c];
                plane[(dual_x + c) * count + k] = dual[c];
            }
        }
        // 2. The blended frames normalised and applied, four vertices at a time (this loop
        //    vectorises: the square roots and divisions were the scalar pass's long chain).
        apply_blended_frames(planes, k0, k1);
        // 3. Out to the vertices; a vertex whose frames cancel keeps the convex combination.
        for (int k = k0; k != k1; ++k) {
            const BlendedVertex& row = blended_vertices_[k];
            const int v = row.vertex;
            float* j = needs_j(row.vertex) ? &blend_turns_[9 * static_cast<size_t>(k)] : nullptr;
            Float4 p;
            if (plane[norm2_plane * count + k] > 1e-12f) {
                for (int c = 0; c < 3; ++c) p[c] = plane[(position_x + c) * count + k];
                p[3] = 0.0f;
                if (j) {
                    float q[4];
                    for (int c = 0; c < 4; ++c) q[c] = plane[(turn_x + c) * count + k];
                    add_rotation(row.share, q, j);
                }
            } else {  // the frames cancel: the convex combination of every influence
                const float* x = rest + 3 * static_cast<size_t>(v);
                const BlendEntry* const first = blend_entries_.data() + row.first;
                const BlendEntry* const bones_first = first + row.count[0];
                const BlendEntry* const end = bones_first + row.count[1];
                p = Float4{0.0f, 0.0f, 0.0f, 0.0f};
                if (j)
                    for (int c = 0; c < 9; ++c) j[c] = 0.0f;
                for (const BlendEntry* f = first; f != bones_first; ++f) {
                    p += load4(at.p4 + 4 * static_cast<size_t>(f->index - block_first));
                    if (j) add_slot_turn(1.0f, turn_of(f->index), j);
                }
                float all[3] = {0.0f, 0.0f, 0.0f};
                for (const BlendEntry* f = bones_first; f != end; ++f) {
                    bones[f->index].apply_add(f->weight, x, all);
                    if (j) add_bone_turn(f->weight, bones[f->index], j);
                }
                p += load3(all);
            }
            store(v, p, j);
        }
    };
    // One parallel loop over blocks of vertices, each evaluating its influences, then doing
    // its plain and its blended vertices: one wait for the threads, and no two threads writing
    // the same cache lines of `out`. Each block a task of its own (simple_partitioner): the
    // blocks' costs differ (a key's vertices, a sweep's end), and with TBB's default chunks the
    // fixture's frame took 0.380-0.393 ms hot against 0.357-0.368 (four rounds alternating).
    const int blocks = static_cast<int>(block_plain_.size()) - 1;
    tbb::parallel_for(
        tbb::blocked_range<int>(0, blocks, 1),
        [&](const tbb::blocked_range<int>& r) {
            // One per thread, shared by every kernel: a block's use of it ends within the task,
            // which runs nothing else meanwhile (a kernel's own per thread would hold 150 KB per
            // character per thread of Blender's pool).
            static thread_local std::vector<float> scratch;
            for (int i = r.begin(); i != r.end(); ++i) {
                {
                    const FlushDenormals flush;
                    // The block's slots' outputs in this thread's scratch, which stays in its cache
                    // from block to block (in planes of every slot, a frame wrote 3.5 MB at 75K
                    // vertices and read them back).
                    const int32_t first = block_slots_[i], n = block_slots_[i + 1] - first;
                    if (scratch.size() < 12 * static_cast<size_t>(n)) scratch.resize(12 * static_cast<size_t>(n));
                    const FrameSlots at{slots.u + first,  slots.w + first,   slots.x + first,   slots.y + first,
                                        slots.z + first,  slots.cos + first, slots.sin + first, slots.rx + first,
                                        slots.ry + first, slots.rz + first,  slots.rw + first,  slots.vx + first,
                                        slots.vy + first, slots.vz + first,  scratch.data(),    scratch.data() + 4 * n};
                    batches(i, at, first);
                    plain_block(block_plain_[i], block_plain_[i + 1], at.p4, first);
                    blended_block(block_blended_[i], block_blended_[i + 1], at, first);
                }
                // (in the thread's own floating-point mode, as the caller's separate passes would be)
                if (maps.after_block) (*maps.after_block)(i);
            }
        },
        tbb::simple_partitioner{});
}

}  // namespace sd
