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
#include <tbb/info.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>

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

void BM_SweepDeform(benchmark::State& state) {
    Case& c = *g_case;
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

void BM_LinearBlendSkinning4(benchmark::State& state) {
    Case& c = *g_case;
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

// Interleaved repetitions and their median keep the ratio honest on a machine whose load
// changes during the run.
BENCHMARK(BM_SweepDeform)
    ->Arg(1)
    ->Arg(0)
    ->ArgName("volume")
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
BENCHMARK(BM_LinearBlendSkinning4)
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
    benchmark::Initialize(&argc, argv);
    Case c;
    const auto t0 = std::chrono::steady_clock::now();
    sd::bench::MotionCase motion = sd::bench::load_motion_case(data);
    c.character = std::move(motion.character);
    c.poses = std::move(motion.poses);
    c.fit = std::make_unique<sd::fit::FitResult>(sd::fit::fit_rig(fit_input(c.character)));
    c.deformer = std::make_unique<sd::Deformer>(c.fit->rig, bind_fitted(c.character, *c.fit));
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
    const double sweep = ms("BM_SweepDeform/volume:1"), sweep_nv = ms("BM_SweepDeform/volume:0");
    const double lbs = ms("BM_LinearBlendSkinning4"), fit_bind = ms("BM_FitAndBind");
    const double frames = ms("BM_SweepDeformFrames");
    if (sweep > 0 && lbs > 0) {
        std::printf("\nFIGURES (%d vertices)\n", V);
        std::printf("  sweep deformation, volume control on : %.3f ms/frame\n", sweep);
        std::printf("  sweep deformation, volume control off: %.3f ms/frame\n", sweep_nv);
        std::printf("  linear blend skinning, 4 influences  : %.3f ms/frame\n", lbs);
        std::printf("  ratio sweep / LBS                    : %.2f (target <= 1.0)\n", sweep / lbs);
        if (frames > 0) {
            std::printf("  sweep deformation with J (shape keys): %.3f ms/frame\n", frames);
            std::printf("  ratio sweep with J / LBS             : %.2f\n", frames / lbs);
        }
        std::printf("  fit + bind (chains, keys, regions)   : %.1f ms (target <= 2000)\n", fit_bind);
    }
    return 0;
}
