// The kernel's per-slot arrays (structure of arrays) in one buffer, each array starting a
// sixteenth of a page further into its page than the one before.
//
// A batch of the kernel reads fourteen arrays and writes two at the same slot index. As
// separate vectors they were wherever the allocator put them: large ones mmap'd at the same
// offset into a page, so that one slot's entries in every array fell into the same cache set
// (16 streams, 8 ways in L1), or packed one after another, so the layout changed with the
// allocator's history. sweep_bench (MakeHuman 80K, two threads) varies between processes and
// over time on this machine, 0.43-0.47 ms in most runs and about 1.0 in slow spells that LBS
// does not show; with every array mmap'd the old layout ran slow in five runs of six, with none
// mmap'd 0.82 in all six. With this layout, ten runs alternating with the old build: the same
// 0.42-0.47 in its fast runs, 0.64-0.90 against 0.99-1.03 in the slow ones (docs/figures.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace sd {

class SlotPlanes {
public:
    SlotPlanes() = default;
    SlotPlanes(SlotPlanes&&) = default;
    SlotPlanes& operator=(SlotPlanes&&) = default;
    // (A copy's buffer could sit at another offset into its page than the original's.)
    SlotPlanes(const SlotPlanes&) = delete;
    SlotPlanes& operator=(const SlotPlanes&) = delete;

    /// Plane p holds sizes[p] floats, zeroed.
    void resize(const std::vector<size_t>& sizes);

    float* operator[](int plane) { return base() + offsets_[plane]; }
    const float* operator[](int plane) const { return const_cast<SlotPlanes*>(this)->base() + offsets_[plane]; }
    size_t size(int plane) const { return sizes_[plane]; }

    static constexpr size_t kPageFloats = 1024;  // 4 KiB
    static constexpr size_t kStaggerFloats = kPageFloats / 16;

private:
    float* base() {
        const auto at = reinterpret_cast<std::uintptr_t>(storage_.data());
        const std::uintptr_t page = kPageFloats * sizeof(float);
        return storage_.data() + ((page - at % page) % page) / sizeof(float);
    }
    std::vector<float> storage_;
    std::vector<size_t> offsets_, sizes_;  // in floats, from the first page boundary of storage_
};

}  // namespace sd
