// The virtual vertices on the sides of the final pass's TIN box (final_pass.cpp, step 3).
// Private to cpp/src.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/final_pass.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg::final_pass_border {

// A vertex of the TIN: the lowest ground point of a cell.
struct Vertex {
    std::int32_t x, y;  // grid
    double z;
    std::uint32_t i;
};

// The virtual vertices on the sides of the TIN's box. With the corners alone each side is
// one edge of the TIN, and the strip between the outermost vertices and the side takes
// heights interpolated towards corners hundreds of metres away; on a slope the lowest
// point of each cell of the outermost row lies on its downhill side, so the uphill strip,
// up to a cell wide, was left above that surface and lost its ground.
//
// So each vertex v of a cell of the lattice's outermost row or column on a side gets a
// virtual vertex there, at its own position moved straight onto the side, at the height
//     min(z_v + max(z_v - z_w, 0) * min(d_side / d_vw, 1), z_o):
//   - w is the vertex of the next cell inwards; d_side and d_vw are grid distances across
//     the side (v to the side, w to v); without such a w, or where d_vw is 0, z_v;
//   - o is the filter's ground point in v's cell nearest the side (ties: the lowest, then
//     the smallest index), so z_o >= z_v.
// A rise towards the side is continued, by at most its own height; a drop is not: there
// the lowest point already lies next to the side, and a drop from an object's top to the
// ground beside it would sink the side below the ground. The cap z_o keeps a rise from
// the ground to an object cut by the side (a roof as v's cell's lowest point) from
// lifting the side above what the filter took there.
//
// A lattice one cell wide or high gets none (its points lie in one strip), nor does a
// vertex within one grid step of a corner along the side (the corner's triangles cover
// it): there a side vertex, a corner and the vertex would stand within a grid step of
// each other, which in a wide box is more than the reference's qhull resolves (a wall,
// a far point: test_final_pass.py, test_far_points.py). Of two at one position
// (vertices of neighbouring cells snapped to one grid line), the lower cell's stays.
// Returned around the box (bottom, right, top, left, each in that direction), so that
// each lies next to the one before. `cells` (per vertex): its cell's column and row in
// `lattice`; `rim`: rim_points' list, the filter's ground (as the final pass reads it)
// in the outermost cells.
std::vector<BorderVertex> border_vertices(const std::vector<Vertex>& vertices,
                                          const std::vector<std::array<std::int64_t, 2>>& cells,
                                          const std::vector<std::uint32_t>& rim, PointsView points,
                                          const CellLattice& lattice, const SnappedPoints& snapped);

// The points i with ground[i] in the outermost cells of `lattice` (none when it is one
// cell wide or high), in index order.
std::vector<std::uint32_t> rim_points(PointsView points, const bool* ground,
                                      const CellLattice& lattice);

// The same for points in a SnappedPoints' order with their cells (snapped.cell on
// `lattice`), ground by position; their input indices, in no particular order.
std::vector<std::uint32_t> rim_points(const SnappedPoints& snapped, const unsigned char* ground,
                                      const CellLattice& lattice);

// Whether a lies before b by place (x, then y).
bool by_place(const BorderVertex& a, const BorderVertex& b);

}  // namespace pcl_rg::final_pass_border
