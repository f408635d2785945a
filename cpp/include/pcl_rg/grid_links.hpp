// The components of the grid ground filter's link graph (algorithms.md section 3, step
// 4): a lock-free union-find fed in parallel. Part of grid_ground, split out to keep
// files small.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "pcl_rg/grid_cells.hpp"
#include "pcl_rg/grid_ground.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

// Disjoint sets that many threads may unite at once (lock-free): a root is only ever
// linked, by compare-and-swap, under a smaller root, and path halving only shortens
// paths, so every pointer ever seen joins two members of one set. The partition at the
// end is the same whatever the interleaving; only the representatives may differ.
class ConcurrentDisjointSets {
   public:
    /// `size` singletons, every parent written in parallel (the array is an UnfilledVector,
    /// not zero-filled first): before each labelling from scratch.
    void reset(std::size_t size) {
        // Atomics cannot be moved, so the array is made anew, not resized.
        if (parent_.size() != size) parent_ = UnfilledVector<std::atomic<std::uint32_t>>(size);
        const auto n = static_cast<std::ptrdiff_t>(parent_.size());
        const bool parallel = parent_.size() >= kGridParallelMin;
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t i = 0; i < n; ++i)
            parent_[i].store(static_cast<std::uint32_t>(i), std::memory_order_relaxed);
    }

    std::uint32_t find(std::uint32_t x) {
        for (;;) {
            std::uint32_t p = parent_[x].load(std::memory_order_acquire);
            if (p == x) return x;
            const std::uint32_t grand = parent_[p].load(std::memory_order_acquire);
            if (grand != p)
                parent_[x].compare_exchange_weak(p, grand, std::memory_order_acq_rel,
                                                 std::memory_order_relaxed);
            x = grand;
        }
    }

    void unite(std::uint32_t a, std::uint32_t b) {
        for (;;) {
            a = find(a);
            b = find(b);
            if (a == b) return;
            if (a < b) std::swap(a, b);
            std::uint32_t expected = a;  // a must still be a root to be linked under b
            if (parent_[a].compare_exchange_strong(expected, b, std::memory_order_acq_rel,
                                                   std::memory_order_relaxed))
                return;
        }
    }

   private:
    UnfilledVector<std::atomic<std::uint32_t>> parent_;
};

/// Components of the link graph among the candidates, in `sets`, after Afforest (Sutton,
/// Ben-Nun and Barak, "Optimizing parallel graph connectivity computation via subgraph
/// sampling", IPDPS 2018): (1) each candidate unites with two linked neighbours, sought
/// from a pseudo-random cell and place, which already joins most of every large
/// component; (2) a snapshot of the roots lets
/// the full pass skip, without a test, every pair already joined; (3) across blocks the
/// terrain is mostly one giant component, the most frequent root of a sample, and points
/// in it are skipped altogether, which is exact: an edge between the giant and another
/// point is tested from that point, whose pass visits all its neighbours. Cells of many
/// points (crowded, grid_cells.hpp) are sampled near each point's height, scanned only
/// at the heights their XY box allows and stepped over by runs (grid_links.cpp), so that
/// a dense spot of distinct points does not cost quadratic time.
/// `root` is scratch space (resized to N and overwritten), so that the caller's passes
/// reuse one array instead of faulting in a fresh one each.
void label_components(const CellGrid& grid, const GridGroundParams& params,
                      const std::vector<unsigned char>& candidate, ConcurrentDisjointSets& sets,
                      UnfilledVector<std::uint32_t>& root);

/// Components after candidates were added: `sets` holds the components of the link graph
/// among `before`, a subset of `candidate`, so only the links of the added points are
/// tested. Exact: the link graph of the larger set is the smaller one's plus the links
/// that have an added point at one end, and those are all tested from that point.
void add_to_components(const CellGrid& grid, const GridGroundParams& params,
                       const std::vector<unsigned char>& candidate,
                       const std::vector<unsigned char>& before, ConcurrentDisjointSets& sets);

}  // namespace pcl_rg
