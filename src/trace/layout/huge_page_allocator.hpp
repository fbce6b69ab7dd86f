// SPDX-License-Identifier: MIT
// An allocator that backs large arrays with 2 MiB pages where the kernel allows it (transparent huge
// pages in "madvise" mode, the Debian default). Traversal touches nodes and triangles all over a
// tree of tens of MiB; with 4 KiB pages nearly every fetch also misses the TLB. Embree does the same.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdlib>
#include <new>

namespace spacebvh::trace {

template <typename T>
struct HugePageAllocator {
    using value_type = T;
    static constexpr size_t kHugePage = size_t(2) << 20;

    HugePageAllocator() = default;
    template <typename U>
    HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

    T* allocate(size_t count) {
        const size_t bytes = count * sizeof(T);
        if (bytes < kHugePage) {
            void* memory = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
            if (!memory) throw std::bad_alloc();
            return static_cast<T*>(memory);
        }
        const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
        void* memory = std::aligned_alloc(kHugePage, rounded);
        if (!memory) throw std::bad_alloc();
        madvise(memory, rounded, MADV_HUGEPAGE);  // a hint: without THP it simply stays 4 KiB pages
        return static_cast<T*>(memory);
    }
    void deallocate(T* pointer, size_t) noexcept { std::free(pointer); }

    template <typename U>
    bool operator==(const HugePageAllocator<U>&) const noexcept {
        return true;
    }
};

}  // namespace spacebvh::trace
