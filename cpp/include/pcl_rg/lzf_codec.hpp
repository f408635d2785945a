// LZF compression as PCD's binary_compressed format uses it (liblzf, BSD-2-Clause).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pcl_rg {

/// Decompresses `size` bytes into exactly `expected_size` bytes; throws
/// std::invalid_argument when the data is corrupt or decompresses to another size.
std::vector<std::uint8_t> lzf_decompress(const std::uint8_t* data, std::size_t size,
                                         std::size_t expected_size);

/// Compresses `size` bytes; the result may be slightly larger than the input when
/// the data does not compress.
std::vector<std::uint8_t> lzf_compress(const std::uint8_t* data, std::size_t size);

}  // namespace pcl_rg
