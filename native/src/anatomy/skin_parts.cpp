#include "anatomy/skin_parts.h"

namespace sd::anatomy {

SkinParts SkinParts::from_binding(const Rig& rig, const Binding& b) {
    const int V = b.vertex_count();
    SkinParts p;
    p.part.assign(V, -1);
    p.sweep.assign(V, -1);
    p.span.assign(V, 0);
    p.u.assign(V, 0.0f);
    p.t.assign(V, 0.0f);
    p.weight.assign(V, 0.0f);
    p.local.assign(3 * static_cast<size_t>(V), 0.0f);
    for (int v = 0; v < V; ++v) {
        float best = 0.0f, total = 0.0f;
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) total += b.sweep_influences[i].weight;
        for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i) total += b.bone_influences[i].weight;
        if (!(total > 0.0f)) total = 1.0f;
        for (uint32_t i = b.sweep_offsets[v]; i < b.sweep_offsets[v + 1]; ++i) {
            const SweepInfluence& f = b.sweep_influences[i];
            if (f.weight > best) {
                best = f.weight;
                const Sweep& s = rig.sweeps[f.sweep];
                p.sweep[v] = f.sweep;
                p.span[v] = f.span;
                p.u[v] = f.u;
                const auto& knots = s.rest_geometry.knots();
                p.t[v] = static_cast<float>(knots[f.span] + f.u * (knots[f.span + 1] - knots[f.span]));
                p.weight[v] = f.weight / total;
                for (int k = 0; k < 3; ++k) p.local[3 * v + k] = f.local[k];
                p.part[v] = s.keys[f.span].bone;
            }
        }
        float best_bone = 0.0f;
        int bone = -1;
        for (uint32_t i = b.bone_offsets[v]; i < b.bone_offsets[v + 1]; ++i)
            if (b.bone_influences[i].weight > best_bone) {
                best_bone = b.bone_influences[i].weight;
                bone = b.bone_influences[i].bone;
            }
        if (bone >= 0 && best_bone > best) p.part[v] = bone;
    }
    return p;
}

}  // namespace sd::anatomy
