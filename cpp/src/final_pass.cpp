// Final pass of a ground filter: classify every point by its height above a TIN of the
// filter's ground. TerraScan (Terrasolid, "Classify by distance to ground TIN" after its
// ground routine) adds the points close to the final ground TIN, so that ground is
// complete where the densification stopped early; the threshold grows with the TIN's
// gradient as in Zhao et al., "Improved progressive TIN densification filtering algorithm
// for airborne LiDAR data in forested areas", ISPRS J. Photogrammetry and Remote Sensing
// 117, 2016 (slope-adaptive thresholds). Here the TIN is built from the lowest ground
// point of each cell, so a filter whose ground holds low objects (a grid grower's) gets
// a lower, smoother surface, and every point, the filter's ground included, is classified
// again by its height above it.
//
// The steps, and the choices that make the result exact (the NumPy reference in
// pcl_rg/reference/_final_pass.py implements the same):
//   1. XY is snapped to the integer grid of a GridFrame over the extent (delaunay.hpp),
//      from the minimum corner, as tin_ground.cpp does; z is float64 from the minimum z.
//   2. Cells of `cell` metres, anchored at multiples of `cell` in world coordinates
//      (lattice_floor, points.hpp); the lowest ground point of each (ties: smallest
//      index) is a vertex. Of vertices on one snapped XY, the lowest (ties: index) stays.
//   3. Delaunay TIN of the vertices inside the frame's box, whose four corners are
//      virtual vertices at the height of their nearest vertex (exact squared grid
//      distance, ties: smallest index).
//   4. Each point p is located in the triangle holding p + (eps, eps^2) (unique whatever
//      the walk); with the triangle's vertices counter-clockwise from the
//      lexicographically smallest (x, y), v0, v1, v2 in metres, n = (v1 - v0) x (v2 - v0):
//        z_TIN = z0 - (nx * (px - x0) + ny * (py - y0)) / nz,
//        grad  = sqrt(nx * nx + ny * ny) / nz,
//      and p is ground when z_p - z_TIN >= -below and z_p - z_TIN <= above + slope * grad.
// The result depends on the insertion order only where the Delaunay triangulation is
// not unique (four or more co-circular vertices); the tests run in parallel and write
// only their own point's entry.
#include "pcl_rg/final_pass.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "pcl_rg/check.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

void validate(const FinalPassParams& params) {
    check::real("final_cell", params.cell, check::non_negative());
    check::real("final_above", params.above, check::non_negative());
    check::real("final_below", params.below, check::non_negative());
    check::real("final_slope", params.slope, check::non_negative());
}

void final_pass(PointsView points, const FinalPassParams& params, bool* ground) {
    const std::size_t n = points.size;
    if (n == 0) return;
    const Interruption interruption;
    const std::array<double, 3> origin = local_origin(points);
    const std::array<double, 3> upper = upper_corner(points, origin);
    const double ex = upper[0] - origin[0], ey = upper[1] - origin[1];
    if (!std::isfinite(ex) || !std::isfinite(ey) || !std::isfinite(upper[2] - origin[2]))
        throw std::invalid_argument("points: the extent is too large (not finite in float64)");
    const double cell_x0 = lattice_floor(origin[0], params.cell);
    const double cell_y0 = lattice_floor(origin[1], params.cell);
    if (!((upper[0] - cell_x0) / params.cell < 0x1p40 &&
          (upper[1] - cell_y0) / params.cell < 0x1p40))
        throw std::invalid_argument(
            "final_cell is too small for the extent of points: more than 2^40 cells per axis");
    const GridFrame frame = make_grid_frame(0.0, 0.0, ex, ey);
    std::vector<std::int32_t> gx, gy;
    snap_to_grid(points, origin, frame, gx, gy);
    auto z_of = [&](std::size_t i) { return points.coord(i, 2) - origin[2]; };

    // --- 2. the lowest ground point of each cell ------------------------------------
    struct Candidate {
        std::int64_t cx, cy;
        double z;
        std::uint32_t i;
    };
    const auto cell_of = [&](std::size_t i) {
        return std::make_pair(
            static_cast<std::int64_t>(std::floor((points.coord(i, 0) - cell_x0) / params.cell)),
            static_cast<std::int64_t>(std::floor((points.coord(i, 1) - cell_y0) / params.cell)));
    };
    auto lower = [](const Candidate& a, const Candidate& b) {
        return a.z < b.z || (a.z == b.z && a.i < b.i);
    };
    const double ncx = std::floor((upper[0] - cell_x0) / params.cell) + 1.0;
    const double ncy = std::floor((upper[1] - cell_y0) / params.cell) + 1.0;
    std::vector<Candidate> vertices;
    if (ncx * ncy <= static_cast<double>(n)) {
        // A dense grid of the cells, no larger than the cloud: the lowest per cell by a
        // scan (each thread its share into its own grid when the grid is small, then
        // merged); the lowest under a total order does not depend on the sharing.
        const auto width = static_cast<std::int64_t>(ncy);
        const auto cells = static_cast<std::size_t>(ncx * ncy);
        std::vector<std::int64_t> lowest(cells, -1);
        auto keep_lower = [&](std::int64_t& b, std::int64_t i) {
            if (b < 0 || z_of(static_cast<std::size_t>(i)) < z_of(static_cast<std::size_t>(b)) ||
                (z_of(static_cast<std::size_t>(i)) == z_of(static_cast<std::size_t>(b)) && i < b))
                b = i;
        };
        const auto count = static_cast<std::int64_t>(n);
#pragma omp parallel if (cells <= n / 8 && count > 65536)
        {
            std::vector<std::int64_t> mine(cells, -1);
#pragma omp for schedule(static) nowait
            for (std::int64_t i = 0; i < count; ++i) {
                if (!ground[i]) continue;
                const auto [cx, cy] = cell_of(static_cast<std::size_t>(i));
                keep_lower(mine[static_cast<std::size_t>(cx * width + cy)], i);
            }
#pragma omp critical(pcl_rg_final_pass_lowest)
            for (std::size_t k = 0; k < cells; ++k)
                if (mine[k] >= 0) keep_lower(lowest[k], mine[k]);
        }
        for (const std::int64_t i : lowest)
            if (i >= 0)
                vertices.push_back(
                    {0, 0, z_of(static_cast<std::size_t>(i)), static_cast<std::uint32_t>(i)});
    } else {
        std::vector<Candidate> candidates;
        for (std::size_t i = 0; i < n; ++i)
            if (ground[i]) {
                const auto [cx, cy] = cell_of(i);
                candidates.push_back({cx, cy, z_of(i), static_cast<std::uint32_t>(i)});
            }
        std::sort(candidates.begin(), candidates.end(),
                  [&](const Candidate& a, const Candidate& b) {
                      return a.cx < b.cx ||
                             (a.cx == b.cx && (a.cy < b.cy || (a.cy == b.cy && lower(a, b))));
                  });
        for (std::size_t k = 0; k < candidates.size(); ++k)
            if (k == 0 || candidates[k].cx != candidates[k - 1].cx ||
                candidates[k].cy != candidates[k - 1].cy)
                vertices.push_back(candidates[k]);
    }
    std::fill(ground, ground + n, false);
    if (vertices.empty()) return;
    // Of vertices on one snapped XY, the lowest (ties: smallest index).
    for (Candidate& v : vertices) v.cx = gx[v.i], v.cy = gy[v.i];
    std::sort(vertices.begin(), vertices.end(), [&](const Candidate& a, const Candidate& b) {
        return a.cx < b.cx || (a.cx == b.cx && (a.cy < b.cy || (a.cy == b.cy && lower(a, b))));
    });
    vertices.erase(std::unique(vertices.begin(), vertices.end(),
                               [](const Candidate& a, const Candidate& b) {
                                   return a.cx == b.cx && a.cy == b.cy;
                               }),
                   vertices.end());
    interruption.check_now();

    // --- 3. the TIN: virtual corners, then the vertices in Morton order --------------
    std::array<double, 4> corner_z{};
    {
        const std::int64_t corner_x[4] = {0, frame.width, frame.width, 0};
        const std::int64_t corner_y[4] = {0, 0, frame.height, frame.height};
        for (int c = 0; c < 4; ++c) {
            std::int64_t best_d2 = std::numeric_limits<std::int64_t>::max();
            std::uint32_t best = std::numeric_limits<std::uint32_t>::max();
            for (const Candidate& v : vertices) {
                const std::int64_t dx = v.cx - corner_x[c], dy = v.cy - corner_y[c];
                const std::int64_t d2 = dx * dx + dy * dy;
                if (d2 < best_d2 || (d2 == best_d2 && v.i < best)) best_d2 = d2, best = v.i;
            }
            corner_z[c] = z_of(best);
        }
    }
    Delaunay tin(frame.width, frame.height);
    std::vector<double> vz(corner_z.begin(), corner_z.end());
    {
        std::vector<std::int32_t> vx(vertices.size()), vy(vertices.size());
        for (std::size_t k = 0; k < vertices.size(); ++k) {
            vx[k] = static_cast<std::int32_t>(vertices[k].cx);
            vy[k] = static_cast<std::int32_t>(vertices[k].cy);
        }
        const std::vector<std::uint32_t> order =
            morton_order_2d(vx.data(), vy.data(), vertices.size(), frame.width, frame.height);
        std::int32_t last = 0;
        for (const std::uint32_t k : order) {
            interruption.check();
            bool inserted = false;
            const std::int32_t v = tin.insert(vx[k], vy[k], last, &inserted);
            if (inserted) vz.push_back(vertices[k].z);  // distinct XY: always inserted
            last = tin.vertex_triangle(v);
        }
    }

    // --- 4. classify every point, in Morton order so that walks are short -------------
    const std::vector<std::uint32_t> order =
        morton_order_2d(gx.data(), gy.data(), n, frame.width, frame.height);
    const double q = frame.quantum;
    constexpr std::ptrdiff_t kChunk = 4096;
    const auto m = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel firstprivate(interruption)
    {
        std::int32_t last = 0;
#pragma omp for schedule(dynamic, 1)
        for (std::ptrdiff_t chunk = 0; chunk < (m + kChunk - 1) / kChunk; ++chunk) {
            if (interruption.requested()) continue;
            for (std::ptrdiff_t k = chunk * kChunk; k < std::min(m, (chunk + 1) * kChunk); ++k) {
                const std::uint32_t i = order[k];
                const std::int32_t t = tin.locate(gx[i], gy[i], last);
                last = t;
                std::array<std::int32_t, 3> v = {tin.triangle_vertex(t, 0),
                                                 tin.triangle_vertex(t, 1),
                                                 tin.triangle_vertex(t, 2)};
                int first = 0;
                for (int j = 1; j < 3; ++j) {
                    const std::int32_t a = v[j], b = v[first];
                    if (tin.vertex_x(a) < tin.vertex_x(b) ||
                        (tin.vertex_x(a) == tin.vertex_x(b) && tin.vertex_y(a) < tin.vertex_y(b)))
                        first = j;
                }
                std::rotate(v.begin(), v.begin() + first, v.end());
                double x[3], y[3], z[3];
                for (int j = 0; j < 3; ++j) {
                    x[j] = static_cast<double>(tin.vertex_x(v[j]) - 1) * q;
                    y[j] = static_cast<double>(tin.vertex_y(v[j]) - 1) * q;
                    z[j] = vz[v[j]];
                }
                const double ux = x[1] - x[0], uy = y[1] - y[0], uz = z[1] - z[0];
                const double wx = x[2] - x[0], wy = y[2] - y[0], wz = z[2] - z[0];
                const double nx = uy * wz - uz * wy;
                const double ny = uz * wx - ux * wz;
                const double nz = ux * wy - uy * wx;
                const double px = static_cast<double>(gx[i] - 1) * q;
                const double py = static_cast<double>(gy[i] - 1) * q;
                const double surface = z[0] - (nx * (px - x[0]) + ny * (py - y[0])) / nz;
                const double gradient = std::sqrt(nx * nx + ny * ny) / nz;
                const double dz = z_of(i) - surface;
                ground[i] = dz >= -params.below && dz <= params.above + params.slope * gradient;
            }
        }
    }
    interruption.check();
}

}  // namespace pcl_rg
