// The iterations of progressive TIN densification that leave the TIN as it is, done at
// once (tin_ground.cpp, step 3 of its opening comment). Private to tin_ground.cpp.
#pragma once

#include <cstdint>
#include <vector>

#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

/// Whether grid point (x, y) is a vertex of triangle t: inserting it then adds nothing.
bool on_vertex(const Delaunay& tin, std::int32_t t, std::int32_t x, std::int32_t y);

/// What skip_idle_iterations did.
struct IdleIterations {
    std::int64_t ground = 0;      ///< points that became ground
    std::int64_t iterations = 0;  ///< iterations of the definition done besides this one
};

/// When every point chosen in an iteration equals a vertex of its triangle in XY,
/// inserting them adds nothing, so the next iteration tests the other accepted points
/// against the same TIN, reaches the same verdicts and chooses each triangle's next
/// point by (d, index); so it goes on until some triangle's choice is a new vertex
/// (thousands of copies of one point took an iteration each, every copy tested each
/// time: quadratic). The points waiting in each triangle (accepted, not chosen) are
/// ranked here once, the chosen one at 0: with J the first rank at which some
/// triangle's point is a new vertex, the points ranked below J become ground
/// (is_ground set, retest cleared) and those ranked J are the choices, as J iterations
/// one by one would leave them; the others wait. `waiting` (sorted positions) is taken
/// apart, and `chosen` then holds the rank-J points in sorted order. tri, dist and
/// order: per sorted position, the triangle of the point's test, its d and its input
/// index; sx, sy: its grid XY.
IdleIterations skip_idle_iterations(
    const Delaunay& tin, const UnfilledVector<std::int32_t>& sx,
    const UnfilledVector<std::int32_t>& sy, const UnfilledVector<std::int32_t>& tri,
    const UnfilledVector<double>& dist, const UnfilledVector<std::uint32_t>& order,
    std::vector<std::uint32_t>& waiting, std::vector<std::uint64_t>& retest,
    UnfilledVector<std::uint8_t>& is_ground, UnfilledVector<std::uint32_t>& chosen);

}  // namespace pcl_rg
