// LZF codec for PCD binary_compressed (see lzf_codec.hpp), over Debian's liblzf.
#include "pcl_rg/lzf_codec.hpp"

#include <lzf.h>

#include <limits>
#include <stdexcept>
#include <string>

namespace pcl_rg {

std::vector<std::uint8_t> lzf_decompress(const std::uint8_t* data, std::size_t size,
                                         std::size_t expected_size) {
    constexpr std::size_t limit = std::numeric_limits<unsigned int>::max();
    if (size > limit || expected_size > limit)
        throw std::invalid_argument("LZF block larger than 4 GiB");
    std::vector<std::uint8_t> out(expected_size);
    if (expected_size == 0) return out;
    // liblzf checks every back reference and output bound, so corrupt input gives 0.
    const unsigned int written = ::lzf_decompress(data, static_cast<unsigned int>(size), out.data(),
                                                  static_cast<unsigned int>(expected_size));
    if (written != expected_size)
        throw std::invalid_argument("corrupt LZF data: expected " + std::to_string(expected_size) +
                                    " bytes, decompressed " + std::to_string(written));
    return out;
}

std::vector<std::uint8_t> lzf_compress(const std::uint8_t* data, std::size_t size) {
    if (size > std::numeric_limits<unsigned int>::max() / 2)
        throw std::invalid_argument("LZF block larger than 2 GiB");
    // LZF expands incompressible data by at most one byte in 32, plus a literal header.
    std::vector<std::uint8_t> out(size + size / 32 + 64);
    if (size == 0) return {};
    const unsigned int written = ::lzf_compress(data, static_cast<unsigned int>(size), out.data(),
                                                static_cast<unsigned int>(out.size()));
    if (written == 0) throw std::runtime_error("LZF compression failed");
    out.resize(written);
    return out;
}

}  // namespace pcl_rg
