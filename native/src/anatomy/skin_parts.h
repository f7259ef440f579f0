// Which part of the body each skin vertex belongs to, read from its binding: the link (bone)
// under its heaviest sweep influence — the span between two keys lies on the link of the
// key it starts from — or, for vertices on no sweep, its heaviest bone. Folding uses the
// parts to tell the two sheets of a contact apart (forearm against upper arm, arm against
// chest); bulge and volume use the sweep parameters.
#pragma once

#include "bind/bind.h"
#include "rig/rig.h"

#include <cstdint>
#include <vector>

namespace sd::anatomy {

struct SkinParts {
    std::vector<int32_t> part;   ///< #V link bone (or driving bone); -1 when unbound
    std::vector<int32_t> sweep;  ///< #V heaviest sweep, -1 when on no sweep
    std::vector<int32_t> span;   ///< #V its span
    std::vector<float> u;        ///< #V position in the span
    std::vector<float> t;        ///< #V rest parameter along the sweep (chord-length knots)
    std::vector<float> weight;   ///< #V the influence's weight (of the vertex's total 1)
    std::vector<float> local;    ///< #V*3 rest local coordinates in the ellipse frame

    int vertex_count() const { return static_cast<int>(part.size()); }
    static SkinParts from_binding(const Rig& rig, const Binding& binding);
};

}  // namespace sd::anatomy
