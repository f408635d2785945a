// Idle iterations of progressive TIN densification, done at once (see
// tin_idle_iterations.hpp).
#include "tin_idle_iterations.hpp"

#include <algorithm>
#include <limits>

#include "pcl_rg/index_bitmap.hpp"

namespace pcl_rg {

bool on_vertex(const Delaunay& tin, std::int32_t t, std::int32_t x, std::int32_t y) {
    for (int k = 0; k < 3; ++k) {
        const std::int32_t v = tin.triangle_vertex(t, k);
        if (tin.vertex_x(v) == x && tin.vertex_y(v) == y) return true;
    }
    return false;
}

IdleIterations skip_idle_iterations(
    const Delaunay& tin, const UnfilledVector<std::int32_t>& sx,
    const UnfilledVector<std::int32_t>& sy, const UnfilledVector<std::int32_t>& tri,
    const UnfilledVector<double>& dist, const UnfilledVector<std::uint32_t>& order,
    std::vector<std::uint32_t>& waiting, std::vector<std::uint64_t>& retest,
    UnfilledVector<std::uint8_t>& is_ground, UnfilledVector<std::uint32_t>& chosen) {
    std::sort(waiting.begin(), waiting.end(), [&](std::uint32_t a, std::uint32_t b) {
        if (tri[a] != tri[b]) return tri[a] < tri[b];
        if (dist[a] != dist[b]) return dist[a] < dist[b];
        return order[a] < order[b];
    });
    std::size_t first_new = std::numeric_limits<std::size_t>::max();  // J
    std::size_t last_rank = 0;
    for (std::size_t k = 0, rank = 1; k < waiting.size(); ++k) {
        const std::uint32_t s = waiting[k];
        rank = k > 0 && tri[waiting[k - 1]] == tri[s] ? rank + 1 : 1;
        last_rank = std::max(last_rank, rank);
        if (rank < first_new && !on_vertex(tin, tri[s], sx[s], sy[s])) first_new = rank;
    }
    chosen.clear();
    // This iteration was rank 0's; ranks 1 .. J each had one of their own (with no new
    // vertex anywhere, every rank did, and the next iteration, if a point is left,
    // adds nothing).
    IdleIterations done;
    done.iterations = static_cast<std::int64_t>(std::min(first_new, last_rank));
    for (std::size_t k = 0, rank = 1; k < waiting.size(); ++k) {
        const std::uint32_t s = waiting[k];
        rank = k > 0 && tri[waiting[k - 1]] == tri[s] ? rank + 1 : 1;
        if (rank > first_new) continue;  // tested again next iteration
        is_ground[s] = 1;
        unmark(retest, s);
        ++done.ground;
        if (rank == first_new) chosen.push_back(s);
    }
    std::sort(chosen.begin(), chosen.end());
    return done;
}

}  // namespace pcl_rg
