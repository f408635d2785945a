// LZF codec for PCD binary_compressed (see lzf_codec.hpp), over Debian's liblzf.
#include "pcl_rg/lzf_codec.hpp"

#include <lzf.h>

#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace pcl_rg {

namespace {

// The bytes an LZF block decompresses to, read from its control bytes alone (liblzf's
// format: a control byte below 32 starts a run of that many plus one literal bytes; any
// other is a back reference of (its top 3 bits, 7 meaning 7 plus the next byte) plus 2
// bytes, at a distance of its low 5 bits and the next byte plus 1). So a header's size
// is checked before the output is allocated: LZF expands at most 88-fold, and a block
// of random bytes could claim, and have zeroed, 88 times its size. Scanning stops at
// the first byte past `expected_size`; std::nullopt: a run or reference that reaches
// past the block's end or before the output's start.
std::optional<std::size_t> decompressed_size(const std::uint8_t* data, std::size_t size,
                                             std::size_t expected_size) {
    std::size_t in = 0, out = 0;
    while (in < size && out <= expected_size) {
        const unsigned control = data[in++];
        if (control < 32) {
            const std::size_t run = control + 1;
            if (run > size - in) return std::nullopt;
            in += run;
            out += run;
            continue;
        }
        std::size_t length = control >> 5;
        if (length == 7) {
            if (in == size) return std::nullopt;
            length += data[in++];
        }
        if (in == size) return std::nullopt;
        const std::size_t distance = ((control & 0x1fU) << 8) + data[in++] + 1;
        if (distance > out) return std::nullopt;
        out += length + 2;
    }
    return out;
}

}  // namespace

std::vector<std::uint8_t> lzf_decompress(const std::uint8_t* data, std::size_t size,
                                         std::size_t expected_size) {
    constexpr std::size_t limit = std::numeric_limits<unsigned int>::max();
    if (size > limit || expected_size > limit)
        throw std::invalid_argument("LZF block larger than 4 GiB");
    const std::optional<std::size_t> holds = decompressed_size(data, size, expected_size);
    if (!holds)
        throw std::invalid_argument(
            "corrupt LZF data: a run reaches past the block's end, or a back reference "
            "before the output's start");
    if (*holds != expected_size)
        throw std::invalid_argument("corrupt LZF data: expected " + std::to_string(expected_size) +
                                    " bytes, it holds " +
                                    (*holds > expected_size ? "more" : std::to_string(*holds)));
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
