// What the benchmarks share: fitting + binding as the add-on does it (tests/support), and a
// console reporter that keeps each benchmark's median
// real time so a benchmark can print ratios measured in the same run.
#pragma once

#include "fit_support.h"

#include <benchmark/benchmark.h>

#include <map>
#include <string>
#include <vector>

namespace sd::bench {

using testing::bind_fitted;
using testing::fit_input;

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
