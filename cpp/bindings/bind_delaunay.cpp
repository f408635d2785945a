// Binding of the Delaunay TIN (see cpp/include/pcl_rg/delaunay.hpp), exposed for tests
// of the triangulation itself.
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/delaunay.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

namespace {

using XYArray = py::array_t<double, py::array::c_style>;

std::size_t xy_rows(const XYArray& xy) {
    if (xy.ndim() != 2 || xy.shape(1) != 2)
        throw std::invalid_argument("xy must have shape (M, 2)");
    return static_cast<std::size_t>(xy.shape(0));
}

std::vector<std::int32_t> grid_of(const DelaunayTin& self, const XYArray& xy) {
    return self.to_grid(xy.data(), xy_rows(xy));
}

// The triangulation, if an interrupted batch did not leave records unwritten.
const Delaunay& readable(const DelaunayTin& self) {
    if (self.tin.broken()) throw std::logic_error("Delaunay: unusable after an interrupted batch");
    return self.tin;
}

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

void bind_delaunay(py::module_& m) {
    py::class_<DelaunayTin>(m, "DelaunayTin",
                            "Incremental Delaunay TIN over a box (internal, for tests).")
        .def(py::init<double, double, double, double>(), py::arg("lower_x"), py::arg("lower_y"),
             py::arg("upper_x"), py::arg("upper_y"))
        .def(
            "insert",
            [](DelaunayTin& self, const XYArray& xy, bool batch) {
                const std::vector<std::int32_t> g = grid_of(self, xy);
                py::array_t<std::int32_t> vertex(static_cast<py::ssize_t>(g.size() / 2));
                // The GIL stays held: it is what serialises writers of this object.
                (batch ? self.insert_batch(g.data(), g.size() / 2, vertex.mutable_data())
                       : self.insert(g.data(), g.size() / 2, vertex.mutable_data()));
                return vertex;
            },
            py::arg("xy").noconvert(), py::arg("batch") = false,
            "Insert rows of xy (M, 2) in order; the vertex id of each (an existing one for "
            "a duplicate). batch: through Delaunay::insert_batch, the same triangulation with "
            "other ids, where the ids of points found on a vertex stay unused (dead_vertices), "
            "as do their triangle rows (live).")
        .def(
            "insert_on_border",
            [](DelaunayTin& self, const py::array_t<std::int32_t, py::array::c_style>& grid) {
                if (grid.ndim() != 2 || grid.shape(1) != 2)
                    throw std::invalid_argument("grid must have shape (M, 2)");
                const auto m = static_cast<std::size_t>(grid.shape(0));
                py::array_t<std::int32_t> vertex(static_cast<py::ssize_t>(m));
                self.insert_on_border(grid.data(), m, vertex.mutable_data());
                return vertex;
            },
            py::arg("grid").noconvert(),
            "Insert grid points (M, 2) int32 on the box's border (x in {0, width} or y in {0, "
            "height}) in order; the vertex id of each (a corner's or an earlier one's when "
            "it is one).")
        .def_property_readonly("dead_vertices",
                               [](const DelaunayTin& self) { return self.tin.dead_vertex_count(); })
        .def_property_readonly("live",
                               [](const DelaunayTin& self) {
                                   const Delaunay& tin = readable(self);
                                   const auto t = static_cast<py::ssize_t>(tin.triangle_count());
                                   py::array_t<bool> out(t);
                                   bool* w = out.mutable_data();
                                   for (py::ssize_t i = 0; i < t; ++i)
                                       w[i] = tin.live(static_cast<std::int32_t>(i));
                                   return out;
                               })
        .def(
            "locate",
            [](const DelaunayTin& self, const XYArray& xy) {
                const std::vector<std::int32_t> g = grid_of(self, xy);
                py::array_t<std::int32_t> triangle(static_cast<py::ssize_t>(g.size() / 2));
                std::int32_t* out = triangle.mutable_data();
                without_gil([&] { self.locate(g.data(), g.size() / 2, out); });
                return triangle;
            },
            py::arg("xy").noconvert(),
            "Triangle holding each row of xy (M, 2), perturbed by (eps, eps^2).")
        .def(
            "to_grid",
            [](const DelaunayTin& self, const XYArray& xy) {
                std::vector<std::int32_t> g = grid_of(self, xy);
                const auto m_rows = static_cast<py::ssize_t>(g.size() / 2);
                return to_numpy(std::move(g), {m_rows, 2});
            },
            py::arg("xy").noconvert(), "Integer grid coordinates of xy (M, 2).")
        .def_property_readonly("quantum",
                               [](const DelaunayTin& self) { return self.frame.quantum; })
        .def_property_readonly("vertices",
                               [](const DelaunayTin& self) {
                                   const Delaunay& tin = readable(self);
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
            "triangles",
            [](const DelaunayTin& self) { return triangle_table(readable(self), false); })
        .def_property_readonly("neighbors", [](const DelaunayTin& self) {
            return triangle_table(readable(self), true);
        });

    m.def(
        "delaunay_triangulate",
        [](const XYArray& xy) {
            const std::size_t n = xy_rows(xy);
            const double* v = xy.data();
            std::vector<std::int64_t> triangles;
            without_gil([&] { triangles = delaunay_triangulate(v, n); });
            const auto rows = static_cast<py::ssize_t>(triangles.size() / 3);
            return to_numpy(std::move(triangles), {rows, 3});
        },
        py::arg("xy").noconvert(),
        "Delaunay triangles (T, 3) of the points xy (M, 2), as counter-clockwise row indices "
        "(duplicates: the first row), without the triangles of the virtual box corners.");
}

}  // namespace pcl_rg::bindings
