// The virtual vertices on the sides of the final pass's TIN box: see final_pass_border.hpp.
#include "final_pass_border.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "pcl_rg/index_bitmap.hpp"

namespace pcl_rg::final_pass_border {

namespace {

// The indices index(k) of the entries k < count with on_rim(k), in increasing order,
// marked in parallel by a scan of every entry (typically a few in a thousand are on the
// rim, but all of them in a lattice of a few cells); indices are below count (each
// entry is one point).
template <class OnRim, class Index>
std::vector<std::uint32_t> rim_of(std::size_t count, OnRim on_rim, Index index) {
    std::vector<std::uint64_t> marked((count + 63) / 64, 0);
    const auto entries = static_cast<std::ptrdiff_t>(count);
#pragma omp parallel for schedule(static) if (entries > 65536)
    for (std::ptrdiff_t k = 0; k < entries; ++k)
        if (on_rim(static_cast<std::size_t>(k))) mark(marked, index(static_cast<std::size_t>(k)));
    std::vector<std::uint32_t> rim;
    take_marked(marked, rim);
    return rim;
}

}  // namespace

std::vector<std::uint32_t> rim_points(PointsView points, const bool* ground,
                                      const CellLattice& lattice) {
    const std::int64_t columns = lattice.columns, rows = lattice.rows;
    if (columns == 1 || rows == 1) return {};
    return rim_of(
        points.size,
        [&](std::size_t i) {
            if (!ground[i]) return false;
            const auto [cx, cy] = cell_of(points, lattice, i);
            return cx == 0 || cx == columns - 1 || cy == 0 || cy == rows - 1;
        },
        [](std::size_t i) { return static_cast<std::uint32_t>(i); });
}

std::vector<std::uint32_t> rim_points(const SnappedPoints& snapped, const unsigned char* ground,
                                      const CellLattice& lattice) {
    const std::int64_t columns = lattice.columns, rows = lattice.rows;
    if (columns == 1 || rows == 1) return {};
    // Which cells are outermost, by cell number: no division per point.
    std::vector<unsigned char> outermost(static_cast<std::size_t>(columns * rows), 0);
    for (std::int64_t cy = 0; cy < rows; ++cy)
        outermost[cy] = outermost[(columns - 1) * rows + cy] = 1;
    for (std::int64_t cx = 0; cx < columns; ++cx)
        outermost[cx * rows] = outermost[cx * rows + rows - 1] = 1;
    return rim_of(
        snapped.order.size(),
        [&](std::size_t s) { return ground[s] && outermost[snapped.cell[s]]; },
        [&](std::size_t s) { return snapped.order[s]; });
}

std::vector<BorderVertex> border_vertices(const std::vector<Vertex>& vertices,
                                          const std::vector<std::array<std::int64_t, 2>>& cells,
                                          const std::vector<std::uint32_t>& rim, PointsView points,
                                          const CellLattice& lattice,
                                          const SnappedPoints& snapped) {
    const std::int64_t columns = lattice.columns, rows = lattice.rows;
    const GridFrame& frame = snapped.frame;
    // Per side: bottom, top (rows 0 and rows - 1), left, right (columns 0, columns - 1).
    struct Entry {
        int side;
        std::int64_t along;  // the cell's place along the side
        int depth;           // 0: the outermost cell, 1: the next inwards
        std::size_t k;       // the vertex
    };
    if (columns == 1 || rows == 1) return {};
    std::vector<Entry> entries;
    for (std::size_t k = 0; k < vertices.size(); ++k)
        for (int side = 0; side < 4; ++side) {
            const bool along_x = side < 2;  // bottom and top run along x
            const std::int64_t across = cells[k][along_x ? 1 : 0];
            const std::int64_t count = along_x ? rows : columns;
            const std::int64_t edge = side % 2 == 0 ? 0 : count - 1;
            const std::int64_t inward = side % 2 == 0 ? 1 : count - 2;
            const int depth = across == edge ? 0 : across == inward ? 1 : -1;
            if (depth >= 0) entries.push_back({side, cells[k][along_x ? 0 : 1], depth, k});
        }
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
        return a.side < b.side || (a.side == b.side && (a.along < b.along ||
                                                        (a.along == b.along && a.depth < b.depth)));
    });
    // Per side, the outermost cells with a vertex (by place along the side), and in each
    // the height of the ground point nearest the side (ties: the lowest, then the
    // smallest index): the cap. Each cell holds one such point at least, its vertex.
    struct Outermost {
        std::int64_t gap = std::numeric_limits<std::int64_t>::max();  // grid steps to the side
        double z = 0.0;
        std::size_t i = 0;
    };
    std::array<std::vector<std::int64_t>, 4> edge_cells;
    for (const Entry& e : entries)
        if (e.depth == 0) edge_cells[e.side].push_back(e.along);
    std::array<std::vector<Outermost>, 4> outermost;
    for (int side = 0; side < 4; ++side) outermost[side].resize(edge_cells[side].size());
    // The ground points of the outermost cells (any order: the cap is the least under a
    // total order).
    for (const std::uint32_t i : rim) {
        const auto [cx, cy] = cell_of(points, lattice, i);
        for (int side = 0; side < 4; ++side) {
            const bool along_x = side < 2, upper_side = side % 2 == 1;
            if ((along_x ? cy : cx) != (upper_side ? (along_x ? rows : columns) - 1 : 0)) continue;
            const std::vector<std::int64_t>& cells_here = edge_cells[side];
            const auto at =
                std::lower_bound(cells_here.begin(), cells_here.end(), along_x ? cx : cy);
            if (at == cells_here.end() || *at != (along_x ? cx : cy)) continue;
            const std::int64_t g = along_x ? snapped.grid_y(points, i) : snapped.grid_x(points, i);
            const std::int64_t gap = upper_side ? (along_x ? frame.height : frame.width) - g : g;
            const double z = points.coord(i, 2) - snapped.origin[2];
            Outermost& best = outermost[side][static_cast<std::size_t>(at - cells_here.begin())];
            if (gap < best.gap || (gap == best.gap && (z < best.z || (z == best.z && i < best.i))))
                best = {gap, z, i};
        }
    }
    std::array<std::vector<BorderVertex>, 4> sides;
    std::array<std::size_t, 4> cell_rank{};  // the next outermost cell, per side
    for (std::size_t e = 0; e < entries.size(); ++e) {
        if (entries[e].depth != 0) continue;
        const int side = entries[e].side;
        const Vertex& v = vertices[entries[e].k];
        const bool along_x = side < 2, upper_side = side % 2 == 1;
        const std::int32_t v_across = along_x ? v.y : v.x;
        const std::int32_t side_at = upper_side ? (along_x ? frame.height : frame.width) : 0;
        const std::int64_t d_side = upper_side ? side_at - v_across : v_across - side_at;
        double z = v.z;
        if (e + 1 < entries.size() && entries[e + 1].side == side &&
            entries[e + 1].along == entries[e].along && entries[e + 1].depth == 1) {
            const Vertex& w = vertices[entries[e + 1].k];
            const std::int32_t w_across = along_x ? w.y : w.x;
            const std::int64_t d_vw = upper_side ? v_across - w_across : w_across - v_across;
            if (d_vw > 0)
                z = v.z +
                    std::max(v.z - w.z, 0.0) *
                        std::min(static_cast<double>(d_side) / static_cast<double>(d_vw), 1.0);
        }
        z = std::min(z, outermost[side][cell_rank[side]++].z);
        const BorderVertex b =
            along_x ? BorderVertex{v.x, side_at, z} : BorderVertex{side_at, v.y, z};
        const std::int32_t along = along_x ? v.x : v.y;
        if (along <= 1 || along >= (along_x ? frame.width : frame.height) - 1) continue;
        if (sides[side].empty() || sides[side].back().x != b.x || sides[side].back().y != b.y)
            sides[side].push_back(b);
    }
    // Around the box: bottom left to right, right upwards, top right to left, left down.
    std::vector<BorderVertex> out(sides[0].begin(), sides[0].end());
    out.insert(out.end(), sides[3].begin(), sides[3].end());
    out.insert(out.end(), sides[1].rbegin(), sides[1].rend());
    out.insert(out.end(), sides[2].rbegin(), sides[2].rend());
    return out;
}

bool by_place(const BorderVertex& a, const BorderVertex& b) {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

}  // namespace pcl_rg::final_pass_border
