// What the benchmarks share: the automatic fitting's input from a test character, fitting +
// binding as the add-on does it, and a console reporter that keeps each benchmark's median
// real time so a benchmark can print ratios measured in the same run.
#pragma once

#include "bind.h"
#include "fit/fit_rig.h"

#include <sweepdeform_io/character.h>

#include <benchmark/benchmark.h>

#include <map>
#include <string>
#include <vector>

namespace sd::bench {

/// The fitting's input for a character with its own skin weights (4 per vertex).
inline fit::FitInput fit_input(const io::Character& c) {
    fit::FitInput in;
    in.vertex_count = static_cast<int>(c.positions.size() / 3);
    in.positions = c.positions.data();
    in.triangle_count = static_cast<int>(c.triangles.size() / 3);
    in.triangles = c.triangles.data();
    in.skeleton = Skeleton::from_arrays(static_cast<int>(c.bone_names.size()), c.bone_parents.data(),
                                        c.bone_rest.data(), c.bone_heads.data(), c.bone_tails.data());
    in.bone_names = c.bone_names;
    in.skin_slots = 4;
    in.skin_bones = c.skin_joints.data();
    in.skin_weights = c.skin_weights.data();
    return in;
}

/// Binds the character with the fitted rig and region weights.
inline Binding bind_fitted(const io::Character& c, const fit::FitResult& f) {
    const fit::RegionWeights& w = f.weights;
    return bind_vertices(f.rig, static_cast<int>(c.positions.size() / 3), c.positions.data(), w.sweep_slots,
                         w.sweep_ids.data(), w.sweep_weights.data(), w.bone_slots, w.bone_ids.data(),
                         w.bone_weights.data());
}

/// Console output as usual, plus each benchmark's real time per iteration in ms: the median
/// where there are repetitions, else the single run. Look up by function name.
class RecordingReporter : public benchmark::ConsoleReporter {
public:
    std::map<std::string, double> ms;
    void ReportRuns(const std::vector<Run>& runs) override {
        ConsoleReporter::ReportRuns(runs);
        for (const Run& r : runs) {
            const bool median = r.aggregate_name == "median";
            if (!median && r.run_type != Run::RT_Iteration) continue;
            std::string name = r.run_name.function_name;
            if (!r.run_name.args.empty()) name += "/" + r.run_name.args;
            if (median || !ms.count(name))
                ms[name] = r.GetAdjustedRealTime() * (r.time_unit == benchmark::kMillisecond ? 1.0 : 1e-6);
        }
    }
};

}  // namespace sd::bench
