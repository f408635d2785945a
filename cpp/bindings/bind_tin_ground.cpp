// Binding of pcl_rg::tin_ground (see tin_ground.hpp) and of its Delaunay TIN
// (delaunay.hpp), the latter exposed for tests of the triangulation itself.
#include <limits>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/tin_ground.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

namespace {

using XYArray = py::array_t<double, py::array::c_style>;

std::size_t xy_rows(const XYArray& xy) {
    if (xy.ndim() != 2 || xy.shape(1) != 2)
        throw std::invalid_argument("xy must have shape (M, 2)");
    return static_cast<std::size_t>(xy.shape(0));
}

// A Delaunay box over [lower, upper] in metres, with the GridFrame that snaps to it.
struct DelaunayTin {
    GridFrame frame;
    double upper_x, upper_y;
    Delaunay tin;
    std::int32_t last = 0;  // where the next walk starts

    DelaunayTin(double lx, double ly, double ux, double uy)
        : frame(make_grid_frame(lx, ly, ux, uy)),
          upper_x(ux),
          upper_y(uy),
          tin(frame.width, frame.height) {}

    // Grid coordinates of xy, after checking every row lies within the bounds.
    std::vector<std::int32_t> to_grid(const XYArray& xy) const {
        const std::size_t m = xy_rows(xy);
        const double* v = xy.data();
        std::vector<std::int32_t> g(2 * m);
        for (std::size_t i = 0; i < m; ++i) {
            const double x = v[2 * i], y = v[2 * i + 1];
            if (!(x >= frame.lower_x && x <= upper_x && y >= frame.lower_y && y <= upper_y))
                throw std::invalid_argument("xy row " + std::to_string(i) +
                                            " lies outside the bounds of the triangulation");
            g[2 * i] = frame.grid_x(x);
            g[2 * i + 1] = frame.grid_y(y);
        }
        return g;
    }
};

py::array_t<std::int32_t> triangle_table(const Delaunay& tin, bool neighbours) {
    const auto t = static_cast<py::ssize_t>(tin.triangle_count());
    py::array_t<std::int32_t> out({t, py::ssize_t{3}});
    auto w = out.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < t; ++i)
        for (int k = 0; k < 3; ++k)
            w(i, k) = neighbours ? tin.neighbour(static_cast<std::int32_t>(i), k)
                                 : tin.triangle_vertex(static_cast<std::int32_t>(i), k);
    return out;
}

}  // namespace

void bind_tin_ground(py::module_& m) {
    py::class_<TinGroundParams>(m, "TinGroundParams")
        .def(py::init<>())
        .def_readwrite("max_building_size", &TinGroundParams::max_building_size)
        .def_readwrite("max_terrain_angle", &TinGroundParams::max_terrain_angle)
        .def_readwrite("iteration_angle", &TinGroundParams::iteration_angle)
        .def_readwrite("iteration_distance", &TinGroundParams::iteration_distance)
        .def_readwrite("reduce_angle_edge", &TinGroundParams::reduce_angle_edge)
        .def_readwrite("stop_edge", &TinGroundParams::stop_edge)
        .def_readwrite("near_vertex_distance", &TinGroundParams::near_vertex_distance)
        .def_readwrite("seed_cell", &TinGroundParams::seed_cell)
        .def_readwrite("seed_tolerance", &TinGroundParams::seed_tolerance)
        .def_readwrite("outlier_depth", &TinGroundParams::outlier_depth);

    m.def(
        "tin_ground",
        [](const PointsArray& points, const TinGroundParams& params) {
            const PointsView view = points_view(points);
            py::array_t<bool> ground(static_cast<py::ssize_t>(view.size));
            bool* out = ground.mutable_data();
            TinGroundStats stats;
            without_gil([&] { stats = tin_ground(view, params, out); });
            py::dict info;
            info["seeds"] = stats.seeds;
            info["iterations"] = stats.iterations;
            info["tin_vertices"] = stats.tin_vertices;
            info["tests"] = stats.tests;
            info["prepare_seconds"] = stats.prepare_seconds;
            info["triangulation_seconds"] = stats.triangulation_seconds;
            info["classification_seconds"] = stats.classification_seconds;
            return py::make_tuple(ground, info);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core progressive TIN densification: (ground mask, stats dict). Use pcl_rg.tin_ground.");

    py::class_<DelaunayTin>(m, "DelaunayTin",
                            "Incremental Delaunay TIN over a box (internal, for tests).")
        .def(py::init<double, double, double, double>(), py::arg("lower_x"), py::arg("lower_y"),
             py::arg("upper_x"), py::arg("upper_y"))
        .def(
            "insert",
            [](DelaunayTin& self, const XYArray& xy) {
                const std::vector<std::int32_t> g = self.to_grid(xy);
                const auto m_rows = static_cast<py::ssize_t>(g.size() / 2);
                py::array_t<std::int32_t> vertex(m_rows);
                std::int32_t* out = vertex.mutable_data();
                // The GIL stays held: it is what serialises writers of this object.
                for (py::ssize_t i = 0; i < m_rows; ++i) {
                    bool inserted = false;
                    out[i] = self.tin.insert(g[2 * i], g[2 * i + 1], self.last, &inserted);
                    self.last = self.tin.vertex_triangle(out[i]);
                }
                return vertex;
            },
            py::arg("xy").noconvert(),
            "Insert rows of xy (M, 2) in order; the vertex id of each (an existing one for "
            "a duplicate).")
        .def(
            "locate",
            [](const DelaunayTin& self, const XYArray& xy) {
                const std::vector<std::int32_t> g = self.to_grid(xy);
                const auto m_rows = static_cast<py::ssize_t>(g.size() / 2);
                py::array_t<std::int32_t> triangle(m_rows);
                std::int32_t* out = triangle.mutable_data();
                without_gil([&] {
                    const Interruption interruption;
                    std::int32_t start = self.last;
                    for (py::ssize_t i = 0; i < m_rows; ++i) {
                        interruption.check();
                        start = out[i] = self.tin.locate(g[2 * i], g[2 * i + 1], start);
                    }
                });
                return triangle;
            },
            py::arg("xy").noconvert(),
            "Triangle holding each row of xy (M, 2), perturbed by (eps, eps^2).")
        .def(
            "to_grid",
            [](const DelaunayTin& self, const XYArray& xy) {
                std::vector<std::int32_t> g = self.to_grid(xy);
                const auto m_rows = static_cast<py::ssize_t>(g.size() / 2);
                return to_numpy(std::move(g), {m_rows, 2});
            },
            py::arg("xy").noconvert(), "Integer grid coordinates of xy (M, 2).")
        .def_property_readonly("quantum",
                               [](const DelaunayTin& self) { return self.frame.quantum; })
        .def_property_readonly("vertices",
                               [](const DelaunayTin& self) {
                                   const Delaunay& tin = self.tin;
                                   const auto v = static_cast<py::ssize_t>(tin.vertex_count());
                                   py::array_t<std::int64_t> out({v, py::ssize_t{2}});
                                   auto w = out.mutable_unchecked<2>();
                                   for (py::ssize_t i = 0; i < v; ++i) {
                                       w(i, 0) = tin.vertex_x(static_cast<std::int32_t>(i));
                                       w(i, 1) = tin.vertex_y(static_cast<std::int32_t>(i));
                                   }
                                   return out;
                               })
        .def_property_readonly(
            "triangles", [](const DelaunayTin& self) { return triangle_table(self.tin, false); })
        .def_property_readonly(
            "neighbors", [](const DelaunayTin& self) { return triangle_table(self.tin, true); });

    m.def(
        "delaunay_triangulate",
        [](const XYArray& xy) {
            const std::size_t n = xy_rows(xy);
            const double* v = xy.data();
            std::vector<std::int64_t> triangles;
            without_gil([&] {
                double lo[2] = {0.0, 0.0}, hi[2] = {0.0, 0.0};
                for (int a = 0; a < 2; ++a) {
                    lo[a] = std::numeric_limits<double>::infinity();
                    hi[a] = -lo[a];
                    for (std::size_t i = 0; i < n; ++i) {
                        lo[a] = std::min(lo[a], v[2 * i + a]);
                        hi[a] = std::max(hi[a], v[2 * i + a]);
                    }
                }
                if (n > 0) {
                    const GridFrame frame = make_grid_frame(lo[0], lo[1], hi[0], hi[1]);
                    std::vector<std::int32_t> gx(n), gy(n);
                    for (std::size_t i = 0; i < n; ++i) {
                        gx[i] = frame.grid_x(v[2 * i]);
                        gy[i] = frame.grid_y(v[2 * i + 1]);
                    }
                    Delaunay tin(frame.width, frame.height);
                    std::vector<std::int64_t> point_of_vertex(4, -1);
                    std::int32_t last = 0;
                    const Interruption interruption;
                    for (const std::uint32_t i :
                         morton_order_2d(gx.data(), gy.data(), n, frame.width, frame.height)) {
                        interruption.check();
                        bool inserted = false;
                        const std::int32_t vid = tin.insert(gx[i], gy[i], last, &inserted);
                        if (inserted) point_of_vertex.push_back(i);
                        last = tin.vertex_triangle(vid);
                    }
                    for (std::size_t t = 0; t < tin.triangle_count(); ++t) {
                        std::int64_t ids[3];
                        bool virtual_corner = false;
                        for (int k = 0; k < 3; ++k) {
                            ids[k] = point_of_vertex[tin.triangle_vertex(
                                static_cast<std::int32_t>(t), k)];
                            virtual_corner = virtual_corner || ids[k] < 0;
                        }
                        if (!virtual_corner) triangles.insert(triangles.end(), ids, ids + 3);
                    }
                }
            });
            const auto rows = static_cast<py::ssize_t>(triangles.size() / 3);
            return to_numpy(std::move(triangles), {rows, 3});
        },
        py::arg("xy").noconvert(),
        "Delaunay triangles (T, 3) of the points xy (M, 2), as counter-clockwise row indices "
        "(duplicates: the first row), without the triangles of the virtual box corners.");
}

}  // namespace pcl_rg::bindings
