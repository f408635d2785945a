// The acceptance test of progressive TIN densification (tin_ground.cpp, step 3 of its
// opening comment): a point against the triangle that holds it. Inline, in a header
// private to tin_ground.cpp, as it runs once per point and iteration in the hot loop.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "ground_tin.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg::tin_acceptance {

inline constexpr double kDegToRad = 3.141592653589793 / 180.0;

// Everything one acceptance test needs, fixed for a run.
struct Limits {
    double quantum;
    double iteration_distance;
    double iteration_angle;
    double reduce_angle_edge;
    double stop_edge;
    double near_vertex_distance;
    double sin_angle;    // sin(iteration_angle)
    double cos_terrain;  // cos(max_terrain_angle)
    // cos_terrain rounded up by far more than the rounding errors of terrain_test's
    // shortcut (see there).
    double cos_terrain_up = cos_terrain * (1.0 + 1e-14);
};

struct Verdict {
    bool accepted = false;
    bool stop = false;  // longest edge < stop_edge
    double d = 0.0;
};

// A triangle's plane (ground_tin.hpp) with what every test against it shares, so that
// consecutive points of one triangle (points are tested in Morton order) compute it once.
struct Facet : ground_tin::Plane {
    double longest;    // longest XY edge (m)
    double norm;       // length of the normal
    double sin_limit;  // sine of the (reduced) iteration angle
};

inline Facet facet(const Delaunay& tin, const UnfilledVector<double>& vz, const Limits& lim,
                   std::int32_t t) {
    Facet f;
    static_cast<ground_tin::Plane&>(f) = ground_tin::plane_of(tin, vz, lim.quantum, t);
    double longest2 = 0.0;
    for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3;
        const double dx = f.x[j] - f.x[k], dy = f.y[j] - f.y[k];
        longest2 = std::max(longest2, dx * dx + dy * dy);
    }
    f.longest = std::sqrt(longest2);
    f.norm = std::sqrt(f.nx * f.nx + f.ny * f.ny + f.nz * f.nz);
    f.sin_limit = lim.sin_angle;
    if (f.longest < lim.reduce_angle_edge)
        f.sin_limit = std::sin(lim.iteration_angle * f.longest / lim.reduce_angle_edge * kDegToRad);
    return f;
}

// Distance d from p to the facet's plane and Axelsson's test: d <= iteration_distance
// and asin(d / |p - v_i|) <= the (reduced) iteration angle for every vertex.
inline bool plane_test(const Facet& f, const Limits& lim, double px, double py, double pz,
                       double* d_out) {
    const double num = f.nx * (px - f.x[0]) + f.ny * (py - f.y[0]) + f.nz * (pz - f.z[0]);
    const double d = std::fabs(num) / f.norm;
    *d_out = d;
    if (!(d <= lim.iteration_distance)) return false;
    const double sin_limit = f.sin_limit;
    // r >= near_vertex_distance, and rounding is monotone: then every vertex passes, and
    // the three square roots are not needed (most ground points, close to their facet).
    if (d <= sin_limit * lim.near_vertex_distance) return true;
    for (int k = 0; k < 3; ++k) {
        const double dx = px - f.x[k], dy = py - f.y[k], dz = pz - f.z[k];
        const double r = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), lim.near_vertex_distance);
        if (!(d <= sin_limit * r)) return false;
    }
    return true;
}

// No triangle (p, v_k, v_j) of non-zero XY area steeper than max_terrain_angle.
inline bool terrain_test(const Delaunay& tin, const Facet& f, const Limits& lim, std::int32_t pgx,
                         std::int32_t pgy, double px, double py, double pz) {
    for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3;
        if (orient2d(tin.vertex_x(f.v[k]), tin.vertex_y(f.v[k]), tin.vertex_x(f.v[j]),
                     tin.vertex_y(f.v[j]), pgx, pgy) == 0)
            continue;  // p on this edge: no triangle would be formed with it
        const double ax = f.x[k] - px, ay = f.y[k] - py, az = f.z[k] - pz;
        const double bx = f.x[j] - px, by = f.y[j] - py, bz = f.z[j] - pz;
        const double mx = ay * bz - az * by;
        const double my = az * bx - ax * bz;
        const double mz = ax * by - ay * bx;
        // Shortcut without the square root: |m| <= |mx| + |my| + |mz|, and cos_terrain_up
        // exceeds cos_terrain by far more than the relative rounding of either side (a few
        // units in the last place), so a triangle that passes it passes the test below.
        // Only where no square below can underflow or overflow, so those bounds hold.
        const double az_abs = std::fabs(mz);
        const double manhattan = std::fabs(mx) + std::fabs(my) + az_abs;
        if (az_abs > 0x1p-500 && manhattan < 0x1p500 && az_abs > lim.cos_terrain_up * manhattan)
            continue;
        if (az_abs < lim.cos_terrain * std::sqrt(mx * mx + my * my + mz * mz)) return false;
    }
    return true;
}

// The acceptance test of point p (grid xy, local z) located in the facet's triangle.
inline Verdict evaluate(const Delaunay& tin, const Facet& f, const Limits& lim, std::int32_t pgx,
                        std::int32_t pgy, double pz) {
    const double px = static_cast<double>(pgx - 1) * lim.quantum;
    const double py = static_cast<double>(pgy - 1) * lim.quantum;
    Verdict out;
    out.stop = f.longest < lim.stop_edge;
    const bool pass = plane_test(f, lim, px, py, pz, &out.d);
    out.accepted = pass && terrain_test(tin, f, lim, pgx, pgy, px, py, pz);
    return out;
}

}  // namespace pcl_rg::tin_acceptance
