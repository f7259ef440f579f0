// What the benchmarks share: fitting + binding as the add-on does it (native/character_fit), and a
// console reporter that keeps each benchmark's median
// real time so a benchmark can print ratios measured in the same run.
#pragma once

#include "character_fit.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>
#include <sweepdeform_io/refine.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace sd::bench {

using character_fit::bind_fitted;
using character_fit::fit_input;

/// The shared data's humans/ folder (SWEEPDEFORM_SHARED_DATA_DIR), or "" after printing that
/// `bench` has nothing to measure because the data is not there.
inline std::string humans_dir_or_skip(const char* bench) {
    const std::string dir = std::string(SWEEPDEFORM_SHARED_DATA_DIR) + "/humans/";
    if (std::filesystem::exists(dir + "mh_male_game_engine.glb")) return dir;
    std::printf("%s: ../shared/data not found; nothing to measure (skipped)\n", bench);
    return "";
}

/// The benchmarks' character and motion: MakeHuman male (humans/mh_male_game_engine.glb in
/// the shared data) refined one Catmull–Clark level (80,270 vertices), and `frames` poses of
/// the CMU dance clip of its _anims.glb at 30 fps from t = 1 s.
struct MotionCase {
    io::Character character;
    std::vector<std::vector<float>> poses;
    std::string clip;  ///< name of the clip the poses come from
};

inline MotionCase load_motion_case(const std::string& humans_dir, int frames = 120) {
    MotionCase c;
    c.character = io::refine_catmull_clark(io::load_gltf_character(humans_dir + "mh_male_game_engine.glb"), 1);
    const io::Character anims = io::load_gltf_character(humans_dir + "mh_male_game_engine_anims.glb");
    int clip = 0;
    for (size_t i = 0; i < anims.animations.size(); ++i)
        if (anims.animations[i].name.find("dance") != std::string::npos) clip = static_cast<int>(i);
    for (int f = 0; f < frames; ++f) c.poses.push_back(io::sample_pose(anims, clip, 1.0 + f / 30.0));
    c.clip = anims.animations[clip].name;
    return c;
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
