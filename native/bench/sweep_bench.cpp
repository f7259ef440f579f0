// sweep_bench: milliseconds per frame of the full sweep deformation (all vertices, sweep
// blending, volume control) next to a 4-influence linear-blend-skinning kernel written with
// the same care, on the same vertices and poses, measured in the same run; and the time to
// bind. Prints figures; never fails on speed.
//
// Case: MakeHuman male (../shared/data/humans/mh_male_game_engine.glb), one Catmull–Clark
// level with OpenSubdiv over its triangles: 80,270 vertices (the paper's models have 72,712).
// Poses: the retargeted CMU dance clip of mh_male_game_engine_anims.glb at 30 fps.
// Rig: the automatic fitting (native/src/fit), as the add-on does it.
#include "bench_case.h"
#include "deform/deform.h"
#include "deform/linear_blend_skinning.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>
#include <sweepdeform_io/refine.h>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace {

struct Case {
    sd::io::Character character;
    std::vector<std::vector<float>> poses;
    std::unique_ptr<sd::fit::FitResult> fit;
    std::unique_ptr<sd::Deformer> deformer;
};

using sd::bench::bind_fitted;
using sd::bench::fit_input;

Case* g_case = nullptr;

/// Argument "threads": 0 for TBB's default, 1 for one thread. On a machine shared with other
/// work the one-thread figures are the steadier; both are printed.
std::optional<tbb::global_control> limit_threads(int64_t threads) {
    if (threads <= 0) return std::nullopt;
    return std::optional<tbb::global_control>(std::in_place, tbb::global_control::max_allowed_parallelism,
                                              static_cast<size_t>(threads));
}

void BM_SweepDeform(benchmark::State& state) {
    Case& c = *g_case;
    const auto threads = limit_threads(state.range(1));
    c.deformer->set_volume_preservation(state.range(0) != 0, 1.0);
    std::vector<float> out(c.character.positions.size());
    size_t frame = 0;
    for (auto _ : state) {
        c.deformer->deform(c.poses[frame++ % c.poses.size()].data(), out.data());
        benchmark::DoNotOptimize(out.data());
    }
    state.counters["vertices"] = static_cast<double>(out.size() / 3);
}

/// deform() plus every vertex's local linear map J: the frame of a character with a shape key
/// or a modifier before Sweep Deform (issue 16: "with a shape key active, the same").
void BM_SweepDeformFrames(benchmark::State& state) {
    Case& c = *g_case;
    c.deformer->set_volume_preservation(true, 1.0);
    std::vector<float> out(c.character.positions.size()), frames(3 * c.character.positions.size());
    size_t frame = 0;
    for (auto _ : state) {
        c.deformer->deform_frames(c.poses[frame++ % c.poses.size()].data(), out.data(), frames.data());
        benchmark::DoNotOptimize(frames.data());
    }
}

/// deform() with the top tenth of the body displaced (a face's shape keys): those vertices'
/// J d (sd_deform_displaced), J assembled for them alone.
void BM_SweepDeformDisplaced(benchmark::State& state) {
    Case& c = *g_case;
    c.deformer->set_volume_preservation(true, 1.0);
    const std::vector<float>& rest = c.character.positions;
    std::vector<float> z;
    for (size_t i = 2; i < rest.size(); i += 3) z.push_back(rest[i]);
    std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() * 9 / 10), z.end());
    const float top = z[z.size() * 9 / 10];
    std::vector<int32_t> moved;
    std::vector<float> moves;
    for (size_t v = 0; v < rest.size() / 3; ++v)
        if (rest[3 * v + 2] >= top) {
            moved.push_back(static_cast<int32_t>(v));
            moves.insert(moves.end(), {0.001f, 0.0f, 0.0f});
        }
    std::vector<float> out(rest.size()), turned(moves.size());
    size_t frame = 0;
    for (auto _ : state) {
        c.deformer->deform_displaced(c.poses[frame++ % c.poses.size()].data(), static_cast<int32_t>(moved.size()),
                                     moved.data(), moves.data(), out.data(), turned.data());
        benchmark::DoNotOptimize(turned.data());
    }
}

void BM_LinearBlendSkinning4(benchmark::State& state) {
    Case& c = *g_case;
    const auto threads = limit_threads(state.range(0));
    const int V = static_cast<int>(c.character.positions.size() / 3);
    std::vector<float> out(c.character.positions.size());
    sd::SkeletonPose pose;
    size_t frame = 0;
    for (auto _ : state) {
        // The same per-frame preparation as the sweep path: validate the pose, build matrices.
        pose.set(c.fit->rig.skeleton, c.poses[frame++ % c.poses.size()].data());
        sd::skin_linear_blend4(sd::bone_affines(pose), V, c.character.positions.data(), c.character.skin_joints.data(),
                               c.character.skin_weights.data(), out.data());
        benchmark::DoNotOptimize(out.data());
    }
}

/// Everything the bind operator does: chains, key ellipses, regions, binding.
void BM_FitAndBind(benchmark::State& state) {
    Case& c = *g_case;
    for (auto _ : state) {
        const sd::fit::FitResult f = sd::fit::fit_rig(fit_input(c.character));
        const sd::Binding b = bind_fitted(c.character, f);
        benchmark::DoNotOptimize(b.sweep_influences.data());
    }
}

// Repetitions in random order (main turns random interleaving on) and their median keep the
// ratio honest on a machine whose load changes during the run.
BENCHMARK(BM_SweepDeform)
    ->Args({1, 0})
    ->Args({0, 0})
    ->Args({1, 1})
    ->ArgNames({"volume", "threads"})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(7)
    ->ReportAggregatesOnly();
BENCHMARK(BM_SweepDeformFrames)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(7)
    ->ReportAggregatesOnly();
BENCHMARK(BM_SweepDeformDisplaced)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(7)
    ->ReportAggregatesOnly();
BENCHMARK(BM_LinearBlendSkinning4)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("threads")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(7)
    ->ReportAggregatesOnly();
BENCHMARK(BM_FitAndBind)->UseRealTime()->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace

int main(int argc, char** argv) {
    const std::string data = sd::bench::humans_dir_or_skip("sweep_bench");
    if (data.empty()) return 0;
    // Each repetition of each benchmark in random order, unless the command line says otherwise.
    std::vector<char*> args(argv, argv + argc);
    std::string interleave = "--benchmark_enable_random_interleaving=true";
    bool given = false;
    for (int i = 1; i < argc; ++i)
        given = given || std::string(argv[i]).rfind("--benchmark_enable_random_interleaving", 0) == 0;
    if (!given) args.push_back(interleave.data());
    int count = static_cast<int>(args.size());
    benchmark::Initialize(&count, args.data());
    Case c;
    const auto t0 = std::chrono::steady_clock::now();
    sd::bench::MotionCase motion = sd::bench::load_motion_case(data);
    c.character = std::move(motion.character);
    c.poses = std::move(motion.poses);
    c.fit = std::make_unique<sd::fit::FitResult>(sd::fit::fit_rig(fit_input(c.character)));
    c.deformer = std::make_unique<sd::Deformer>(c.fit->rig, bind_fitted(c.character, *c.fit));
    c.deformer->set_skin_triangles(c.character.triangles);  // as the add-on: the trunk's fill
    const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    g_case = &c;

    const int V = static_cast<int>(c.character.positions.size() / 3);
    std::printf(
        "case: MakeHuman male, 1 Catmull-Clark level: %d vertices, %zu sweeps, clip %s, %d threads (setup %.2f s)\n", V,
        c.fit->rig.sweeps.size(), motion.clip.c_str(), tbb::info::default_concurrency(), setup);
    sd::bench::RecordingReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();

    const auto ms = [&](const std::string& name) {
        const auto it = reporter.ms.find(name);
        return it == reporter.ms.end() ? 0.0 : it->second;
    };
    const double sweep = ms("BM_SweepDeform/volume:1/threads:0"), sweep_nv = ms("BM_SweepDeform/volume:0/threads:0");
    const double lbs = ms("BM_LinearBlendSkinning4/threads:0"), fit_bind = ms("BM_FitAndBind");
    const double sweep1 = ms("BM_SweepDeform/volume:1/threads:1"), lbs1 = ms("BM_LinearBlendSkinning4/threads:1");
    const double frames = ms("BM_SweepDeformFrames"), displaced = ms("BM_SweepDeformDisplaced");
    if (sweep > 0 && lbs > 0) {
        std::printf("\nFIGURES (%d vertices)\n", V);
        std::printf("  sweep deformation, volume control on : %.3f ms/frame\n", sweep);
        std::printf("  sweep deformation, volume control off: %.3f ms/frame\n", sweep_nv);
        std::printf("  linear blend skinning, 4 influences  : %.3f ms/frame\n", lbs);
        std::printf("  ratio sweep / LBS                    : %.2f (target <= 1.0)\n", sweep / lbs);
        if (sweep1 > 0 && lbs1 > 0) {
            std::printf("  one thread: sweep, volume control on : %.3f ms/frame\n", sweep1);
            std::printf("  one thread: linear blend skinning    : %.3f ms/frame\n", lbs1);
            std::printf("  ratio sweep / LBS on one thread      : %.2f (target <= 1.0)\n", sweep1 / lbs1);
        }
        if (frames > 0) {
            std::printf("  sweep deformation with J (shape keys): %.3f ms/frame\n", frames);
            std::printf("  ratio sweep with J / LBS             : %.2f\n", frames / lbs);
        }
        if (displaced > 0) {
            std::printf("  sweep, top tenth displaced (J d)     : %.3f ms/frame\n", displaced);
            std::printf("  ratio sweep with J d / LBS           : %.2f\n", displaced / lbs);
        }
        std::printf("  fit + bind (chains, keys, regions)   : %.1f ms (target <= 2000)\n", fit_bind);
    }
    return 0;
}
