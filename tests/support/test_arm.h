// A synthetic straight arm for analytic tests: three bones along +x (upper arm 0..1,
// forearm 1..2, hand 2..2.3), one sweep of seven key ellipses with constant half-axes, and an
// elliptic cylinder mesh of rings around it.
#pragma once

#include "bind/bind.h"
#include "deform/deform.h"
#include "rig/rig.h"

#include <glm/gtc/matrix_transform.hpp>

#include <vector>

namespace sd::test {

/// Rotation whose columns are (y, z, x): major axis y, minor axis z, normal +x.
inline dquat along_x() { return glm::quat_cast(dmat3(dvec3(0, 1, 0), dvec3(0, 0, 1), dvec3(1, 0, 0))); }

struct Arm {
    static constexpr double kA = 0.10, kB = 0.07;
    Rig rig;
    std::vector<float> mesh;  ///< rings of the elliptic cylinder, #V*3
    int rings = 0, ring_size = 0;
    std::vector<double> ring_x;

    explicit Arm(double a = kA, double b = kB, int ring_count = 49, int segments = 32) {
        const double heads[3] = {0.0, 1.0, 2.0}, tails[3] = {1.0, 2.0, 2.3};
        for (int i = 0; i < 3; ++i) {
            rig.skeleton.parents.push_back(i - 1);
            rig.skeleton.rest.push_back(glm::translate(dmat4(1.0), dvec3(heads[i], 0, 0)));
            rig.skeleton.rest_inverse.push_back(glm::inverse(rig.skeleton.rest.back()));
            rig.skeleton.heads.push_back(dvec3(heads[i], 0, 0));
            rig.skeleton.tails.push_back(dvec3(tails[i], 0, 0));
        }
        // shoulder (follows the upper arm), 2 intermediates, elbow (joint), 2 intermediates,
        // wrist (joint; takes the hand's whole twist, as the radius does).
        const double xs[7] = {0.0, 1.0 / 3, 2.0 / 3, 1.0, 4.0 / 3, 5.0 / 3, 2.0};
        const int bone[7] = {0, 0, 0, 1, 1, 1, 2}, parent[7] = {-1, -1, -1, 0, -1, -1, 1};
        std::vector<KeyEllipse> keys;
        for (int k = 0; k < 7; ++k) {
            KeyEllipse e;
            e.center = dvec3(xs[k], 0, 0);
            e.orientation = along_x();
            e.a = a;
            e.b = b;
            e.bone = bone[k];
            e.joint_parent = parent[k];
            e.twist_fraction = k == 6 ? 1.0 : 0.5;
            keys.push_back(e);
        }
        rig.add_sweep(keys);
        rings = ring_count;
        ring_size = segments;
        for (int r = 0; r < rings; ++r) {
            const double x = 2.0 * r / (rings - 1);
            ring_x.push_back(x);
            for (int s = 0; s < segments; ++s) {
                const double th = 2.0 * M_PI * s / segments;
                mesh.push_back(static_cast<float>(x));
                mesh.push_back(static_cast<float>(a * std::cos(th)));
                mesh.push_back(static_cast<float>(b * std::sin(th)));
            }
        }
    }
    int vertex_count() const { return static_cast<int>(mesh.size() / 3); }

    /// Two triangles per quad between consecutive rings, counter-clockwise seen from outside
    /// (an open tube).
    std::vector<int32_t> ring_triangles() const {
        std::vector<int32_t> t;
        const int n = ring_size;
        for (int r = 0; r + 1 < rings; ++r)
            for (int s = 0; s < n; ++s) {
                const int a = r * n + s, b = r * n + (s + 1) % n, c = (r + 1) * n + (s + 1) % n, d = (r + 1) * n + s;
                t.insert(t.end(), {a, b, c, a, c, d});
            }
        return t;
    }

    Binding bind() const {
        const int V = vertex_count();
        std::vector<int32_t> ids(V, 0);
        std::vector<float> w(V, 1.0f);
        return bind_vertices(rig, V, mesh.data(), 1, ids.data(), w.data(), 0, nullptr, nullptr);
    }

    /// Posed bone matrices (#B*16 floats): elbow bent by `bend` radians about z, hand twisted
    /// by `twist` radians about the forearm axis.
    std::vector<float> pose(double bend, double twist = 0.0) const {
        const dvec3 elbow(1, 0, 0), wrist(2, 0, 0);
        const dmat4 bend_m = glm::translate(dmat4(1.0), elbow) * glm::rotate(dmat4(1.0), bend, dvec3(0, 0, 1)) *
                             glm::translate(dmat4(1.0), -elbow);
        const dmat4 twist_m = glm::translate(dmat4(1.0), wrist) * glm::rotate(dmat4(1.0), twist, dvec3(1, 0, 0)) *
                              glm::translate(dmat4(1.0), -wrist);
        const dmat4 deform[3] = {dmat4(1.0), bend_m, bend_m * twist_m};
        std::vector<float> out;
        for (int b = 0; b < 3; ++b) {
            const dmat4 p = deform[b] * rig.skeleton.rest[b];
            for (int c = 0; c < 4; ++c)
                for (int r = 0; r < 4; ++r) out.push_back(static_cast<float>(p[c][r]));
        }
        return out;
    }
};

}  // namespace sd::test
