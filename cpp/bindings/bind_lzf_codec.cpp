// Binding of the LZF codec used by pcl_rg.io for PCD binary_compressed.
#include <string_view>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/lzf_codec.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_lzf_codec(py::module_& m) {
    m.def(
        "lzf_decompress",
        [](py::bytes data, std::size_t expected_size) {
            const auto in = static_cast<std::string_view>(data);
            std::vector<std::uint8_t> out;
            without_gil([&] {
                out = lzf_decompress(reinterpret_cast<const std::uint8_t*>(in.data()), in.size(),
                                     expected_size);
            });
            return py::bytes(reinterpret_cast<const char*>(out.data()), out.size());
        },
        py::arg("data"), py::arg("expected_size"),
        "Decompress LZF data to exactly expected_size bytes (ValueError if corrupt).");
    m.def(
        "lzf_compress",
        [](py::bytes data) {
            const auto in = static_cast<std::string_view>(data);
            std::vector<std::uint8_t> out;
            without_gil([&] {
                out = lzf_compress(reinterpret_cast<const std::uint8_t*>(in.data()), in.size());
            });
            return py::bytes(reinterpret_cast<const char*>(out.data()), out.size());
        },
        py::arg("data"), "Compress bytes with LZF.");
}

}  // namespace pcl_rg::bindings
