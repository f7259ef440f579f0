// scale_bench: a character of over a million vertices fits, binds and deforms. Prints the
// time of each stage and the process's peak memory; never fails on speed.
//
// Case: MakeHuman male (../shared/data/humans/mh_male_game_engine.glb) refined three
// Catmull–Clark levels with OpenSubdiv (13,380 -> 1,283,906 vertices), posed by the dance clip.
#include "bench_case.h"
#include "deform/deform.h"

#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/gltf_loader.h>
#include <sweepdeform_io/refine.h>

#include <sys/resource.h>

#include <chrono>
#include <cstdio>

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double peak_rss_mib() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss / 1024.0;  // Linux reports KiB
}

}  // namespace

int main(int argc, char** argv) {
    const int levels = argc > 1 ? std::atoi(argv[1]) : 3;
    const std::string data = sd::bench::humans_dir_or_skip("scale_bench");
    if (data.empty()) return 0;
    auto t0 = std::chrono::steady_clock::now();
    const sd::io::Character c =
        sd::io::refine_catmull_clark(sd::io::load_gltf_character(data + "mh_male_game_engine.glb"), levels);
    const sd::io::Character anims = sd::io::load_gltf_character(data + "mh_male_game_engine_anims.glb");
    const int V = static_cast<int>(c.positions.size() / 3);
    std::printf(
        "case: MakeHuman male, %d Catmull-Clark levels: %d vertices, %zu triangles (load+refine %.2f s, peak %.0f "
        "MiB)\n",
        levels, V, c.triangles.size() / 3, seconds_since(t0), peak_rss_mib());

    t0 = std::chrono::steady_clock::now();
    const sd::fit::FitResult fit = sd::fit::fit_rig(sd::bench::fit_input(c));
    const double t_fit = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    sd::Binding binding = sd::bench::bind_fitted(c, fit);
    const double t_bind = seconds_since(t0);
    sd::Deformer deformer(fit.rig, std::move(binding));
    std::vector<float> out(c.positions.size());
    const int frames = 30;
    t0 = std::chrono::steady_clock::now();
    for (int f = 0; f < frames; ++f) deformer.deform(sd::io::sample_pose(anims, 2, 1.0 + f / 30.0).data(), out.data());
    const double t_frame = seconds_since(t0) / frames;
    std::printf("\nFIGURES (%d vertices)\n", V);
    std::printf("  fit (chains, keys, regions): %.2f s\n", t_fit);
    std::printf("  bind                       : %.2f s\n", t_bind);
    std::printf("  deform                     : %.2f ms/frame (incl. sampling the clip)\n", 1000.0 * t_frame);
    std::printf("  peak memory (process)      : %.0f MiB\n", peak_rss_mib());
    return 0;
}
