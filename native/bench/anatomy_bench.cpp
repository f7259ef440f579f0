// anatomy_bench: milliseconds per frame of the whole body with every anatomical effect on
// (sweeps with volume control, muscle bulge, bone protrusion, collision detection in the
// joint regions, skin folding, volume), and the share of each stage; next to the sweeps
// alone, measured in the same run. Prints figures; never fails on speed.
//
// Case: MakeHuman male (../shared/data/humans/mh_male_game_engine.glb), one Catmull–Clark
// level (80,270 vertices), rig fitted automatically (sd::fit), joints: both elbows and knees
// (folding, protrusion, bulge) and both shoulders, both hips and the neck (folding). Poses:
// the retargeted CMU dance clip of mh_male_game_engine_anims.glb at 30 fps.
#include "anatomy/anatomy.h"
#include "bench_case.h"
#include "deform/deform.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>
#include <sweepdeform_io/refine.h>

#include <benchmark/benchmark.h>
#include <time.h>
#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>

namespace {

using sd::anatomy::Anatomy;
using sd::anatomy::AnatomyStats;
using sd::anatomy::JointKind;

struct Case {
    sd::io::Character character;
    std::vector<std::vector<float>> poses;
    sd::fit::FitResult fit;
    sd::Binding binding;
    std::unique_ptr<sd::Deformer> deformer, plain;
    std::unique_ptr<Anatomy> anatomy;
    // Sums over the measured frames of the effects benchmark.
    AnatomyStats sum{};
    int frames = 0, max_before = 0, max_after = 0, unresolved = 0;
    double cpu_ms = 0.0;  // process CPU time inside the effects benchmark
    double worst_total = 0.0;
};

Case* g_case = nullptr;

/// CPU time of the whole process (all threads), ms.
double process_cpu_ms() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

void BM_Sweeps(benchmark::State& state) {
    Case& c = *g_case;
    std::vector<float> out(c.character.positions.size());
    size_t frame = 0;
    for (auto _ : state) {
        c.plain->deform(c.poses[frame++ % c.poses.size()].data(), out.data());
        benchmark::DoNotOptimize(out.data());
    }
}

void BM_SweepsWithAllEffects(benchmark::State& state) {
    Case& c = *g_case;
    std::vector<float> out(c.character.positions.size());
    size_t frame = 0;
    const double cpu0 = process_cpu_ms();
    for (auto _ : state) {
        c.anatomy->deform(*c.deformer, c.poses[frame++ % c.poses.size()].data(), out.data());
        benchmark::DoNotOptimize(out.data());
        const AnatomyStats& s = c.anatomy->stats();
        c.sum.ms_sweeps += s.ms_sweeps;
        c.sum.ms_bulge += s.ms_bulge;
        c.sum.ms_protrusion += s.ms_protrusion;
        c.sum.ms_collision += s.ms_collision;
        c.sum.ms_folding += s.ms_folding;
        c.sum.ms_volume += s.ms_volume;
        c.sum.ms_total += s.ms_total;
        c.sum.pairs_before += s.pairs_before;
        c.sum.pairs_after += s.pairs_after;
        c.sum.folding_iterations += s.folding_iterations;
        c.sum.ms_first_detection += s.ms_first_detection;
        c.sum.rechecks += s.rechecks;
        c.sum.rechecked_triangles += s.rechecked_triangles;
        c.sum.triangle_tests += s.triangle_tests;
        c.max_before = std::max(c.max_before, s.pairs_before);
        c.max_after = std::max(c.max_after, s.pairs_after);
        c.unresolved += s.pairs_after > 0;
        c.worst_total = std::max(c.worst_total, s.ms_total);
        ++c.frames;
    }
    c.cpu_ms += process_cpu_ms() - cpu0;
    state.counters["vertices"] = static_cast<double>(out.size() / 3);
}

BENCHMARK(BM_Sweeps)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(5)
    ->ReportAggregatesOnly();
BENCHMARK(BM_SweepsWithAllEffects)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0)
    ->Repetitions(5)
    ->ReportAggregatesOnly();

}  // namespace

int main(int argc, char** argv) {
    const std::string data = sd::bench::humans_dir_or_skip("anatomy_bench");
    if (data.empty()) return 0;
    benchmark::Initialize(&argc, argv);
    Case c;
    const auto t0 = std::chrono::steady_clock::now();
    sd::bench::MotionCase motion = sd::bench::load_motion_case(data);
    c.character = std::move(motion.character);
    c.poses = std::move(motion.poses);

    const sd::io::Character& ch = c.character;
    const int V = static_cast<int>(ch.positions.size() / 3), T = static_cast<int>(ch.triangles.size() / 3);
    const int B = static_cast<int>(ch.bone_names.size());
    c.fit = sd::fit::fit_rig(sd::bench::fit_input(ch));
    c.binding = sd::bench::bind_fitted(ch, c.fit);
    c.deformer = std::make_unique<sd::Deformer>(c.fit.rig, c.binding);
    c.plain = std::make_unique<sd::Deformer>(c.fit.rig, c.binding);
    const auto t1 = std::chrono::steady_clock::now();
    c.anatomy = std::make_unique<Anatomy>(c.fit.rig, c.binding, ch.triangles.data(), T);
    const sd::dvec3 front = c.fit.chains.frame.forward, back = -front;
    for (size_t i = 0; i < c.fit.chains.chains.size(); ++i) {
        const sd::fit::Chain& chain = c.fit.chains.chains[i];
        if (c.fit.chain_sweep[i] < 0 || chain.bones.size() < 2) continue;
        if (chain.kind == sd::fit::ChainKind::Arm) c.anatomy->add_joint(chain.bones.back(), JointKind::Elbow, &front);
        if (chain.kind == sd::fit::ChainKind::Leg) c.anatomy->add_joint(chain.bones.back(), JointKind::Knee, &back);
    }
    for (size_t i = 0; i < c.fit.chains.chains.size(); ++i) {
        const sd::fit::Chain& chain = c.fit.chains.chains[i];
        if (c.fit.chain_sweep[i] < 0 || chain.kind == sd::fit::ChainKind::Torso ||
            chain.kind == sd::fit::ChainKind::Custom)
            continue;
        try {
            c.anatomy->add_joint(chain.bones[std::min<size_t>(chain.first_swept, chain.bones.size() - 1)],
                                 JointKind::Generic, nullptr);
        } catch (const sd::InvalidInput&) {}
    }
    std::vector<float> warm(ch.positions.size());
    c.anatomy->deform(*c.deformer, c.poses[0].data(), warm.data());  // builds the collision set
    const auto t2 = std::chrono::steady_clock::now();
    g_case = &c;

    std::printf(
        "case: MakeHuman male, 1 Catmull-Clark level: %d vertices, %d triangles, %zu sweeps (fitted), "
        "%d joints, %d triangles in their collision regions, clip %s, %d threads "
        "(setup %.1f s, anatomy %.2f s)\n",
        V, T, c.fit.rig.sweeps.size(), c.anatomy->joint_count(), c.anatomy->stats().collision_triangles,
        motion.clip.c_str(), tbb::info::default_concurrency(), std::chrono::duration<double>(t1 - t0).count(),
        std::chrono::duration<double>(t2 - t1).count());
    sd::bench::RecordingReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();

    const double sweeps = reporter.ms["BM_Sweeps"], all = reporter.ms["BM_SweepsWithAllEffects"];
    if (c.frames > 0 && all > 0) {
        const double n = c.frames;
        const AnatomyStats& s = c.sum;
        const double total = s.ms_total / n;
        std::printf("\nFIGURES (%d vertices, %d frames of the clip measured)\n", V, c.frames);
        std::printf("  sweeps alone (median)                 : %.3f ms/frame\n", sweeps);
        std::printf("  sweeps + all effects (median)         : %.3f ms/frame (target <= 5 ms)\n", all);
        std::printf("  mean of the stages' own timers       : %.3f ms/frame, worst frame %.3f ms\n", total,
                    c.worst_total);
        std::printf("  process CPU time (both threads)       : %.3f ms/frame\n", c.cpu_ms / n);
        const auto row = [&](const char* name, double ms) {
            std::printf("    %-34s %7.3f ms  %5.1f %%\n", name, ms / n, 100.0 * ms / s.ms_total);
        };
        row("sweeps (incl. volume control)", s.ms_sweeps);
        row("muscle bulge", s.ms_bulge);
        row("bone protrusion", s.ms_protrusion);
        row("collision detection", s.ms_collision);
        row("  of which the first full query", s.ms_first_detection);
        row("skin folding", s.ms_folding);
        row("volume (I_C, restoration)", s.ms_volume);
        row("other (pose, bookkeeping)",
            s.ms_total - s.ms_sweeps - s.ms_bulge - s.ms_protrusion - s.ms_collision - s.ms_folding - s.ms_volume);
        std::printf(
            "  intersecting pairs per frame: %.1f before folding (max %d), %.2f after (max %d); "
            "%d of %d frames left with pairs; %.2f folding passes per frame\n",
            s.pairs_before / n, c.max_before, s.pairs_after / n, c.max_after, c.unresolved, c.frames,
            s.folding_iterations / n);
        std::printf("  re-checks per frame %.2f over %.0f triangles; exact triangle tests per frame %.0f\n",
                    s.rechecks / n, static_cast<double>(s.rechecked_triangles) / n,
                    static_cast<double>(s.triangle_tests) / n);
    }
    return 0;
}
