// Radix sorts and the Morton order (see spatial_order.hpp).
#include "pcl_rg/spatial_order.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcl_rg {

namespace {

// One stable counting-sort pass per digit over contiguous per-thread chunks; the
// bucket-major, thread-minor prefix sums put chunk t's items of a bucket after chunk
// t-1's, which keeps the sort stable. `Move` copies item i to slot dst.
template <class DigitOf, class Move>
void radix_pass(std::size_t n, DigitOf digit_of, Move move, std::size_t buckets,
                std::vector<std::size_t>& offsets, int threads) {
    std::fill(offsets.begin(), offsets.end(), 0);
#pragma omp parallel num_threads(threads)
    {
        const int t = omp_get_thread_num();
        const std::size_t begin = n * t / threads, end = n * (t + 1) / threads;
        std::size_t* count = &offsets[t * buckets];
        for (std::size_t i = begin; i < end; ++i) ++count[digit_of(i)];
#pragma omp barrier
#pragma omp single
        {
            std::size_t running = 0;
            for (std::size_t b = 0; b < buckets; ++b)
                for (int u = 0; u < threads; ++u) {
                    const std::size_t c = offsets[u * buckets + b];
                    offsets[u * buckets + b] = running;
                    running += c;
                }
        }
        for (std::size_t i = begin; i < end; ++i) move(i, count[digit_of(i)]++);
    }
}

// Digits of at most 11 bits, as few passes as possible, equal widths.
int digit_width(int bits) {
    const int passes = (bits + 10) / 11;
    return (bits + passes - 1) / passes;
}

int thread_count(std::size_t n) {
    // Small inputs are not worth waking threads for.
    return std::max(1, std::min<int>(omp_get_max_threads(), static_cast<int>(n / 65536) + 1));
}

}  // namespace

void radix_sort_pairs(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& ids,
                      int key_bits) {
    const std::size_t n = keys.size();
    if (n < 2 || key_bits <= 0) return;
    const int width = digit_width(key_bits);
    const std::size_t buckets = std::size_t{1} << width, mask = buckets - 1;
    const int threads = thread_count(n);
    std::vector<std::size_t> offsets(static_cast<std::size_t>(threads) * buckets);
    std::vector<std::uint64_t> keys_tmp(n);
    std::vector<std::uint32_t> ids_tmp(n);
    for (int shift = 0; shift < key_bits; shift += width) {
        radix_pass(
            n, [&](std::size_t i) { return (keys[i] >> shift) & mask; },
            [&](std::size_t i, std::size_t dst) {
                keys_tmp[dst] = keys[i];
                ids_tmp[dst] = ids[i];
            },
            buckets, offsets, threads);
        keys.swap(keys_tmp);
        ids.swap(ids_tmp);
    }
}

void radix_sort_bits(std::vector<std::uint64_t>& values, int first_bit, int last_bit) {
    const std::size_t n = values.size();
    const int bits = last_bit - first_bit;
    if (n < 2 || bits <= 0) return;
    const int width = digit_width(bits);
    const std::size_t buckets = std::size_t{1} << width, mask = buckets - 1;
    const int threads = thread_count(n);
    std::vector<std::size_t> offsets(static_cast<std::size_t>(threads) * buckets);
    std::vector<std::uint64_t> tmp(n);
    for (int shift = first_bit; shift < last_bit; shift += width) {
        radix_pass(
            n, [&](std::size_t i) { return (values[i] >> shift) & mask; },
            [&](std::size_t i, std::size_t dst) { tmp[dst] = values[i]; }, buckets, offsets,
            threads);
        values.swap(tmp);
    }
}

namespace {

// Spreads the low 21 bits of v so that two zero bits separate consecutive bits.
std::uint64_t spread_bits(std::uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

}  // namespace

std::vector<std::uint32_t> morton_order(const float* xyz, std::uint32_t size) {
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = std::numeric_limits<float>::infinity();
        hi[a] = -lo[a];
    }
    for (std::uint32_t i = 0; i < size; ++i)
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], xyz[3 * i + a]);
            hi[a] = std::max(hi[a], xyz[3 * i + a]);
        }
    // One scale for all axes keeps the curve's cells cubic; 10 bits per axis (a
    // 1024^3 grid) is plenty for memory locality, and leaves room to pack the
    // point index below the 30-bit code and sort single 64-bit words.
    constexpr int kAxisBits = 10;
    const float extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30f});
    const double scale = static_cast<double>((1u << kAxisBits) - 1) / extent;
    const int id_bits = std::max(1, bit_width(size));
    std::vector<std::uint64_t> packed(size);
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(size); ++i) {
        std::uint64_t code = 0;
        for (int a = 0; a < 3; ++a) {
            const auto q = static_cast<std::uint64_t>((xyz[3 * i + a] - lo[a]) * scale);
            code |= spread_bits(q) << a;
        }
        packed[i] = code << id_bits | static_cast<std::uint64_t>(i);
    }
    radix_sort_bits(packed, id_bits, id_bits + 3 * kAxisBits);
    std::vector<std::uint32_t> order(size);
    const std::uint64_t id_mask = (std::uint64_t{1} << id_bits) - 1;
#pragma omp parallel for schedule(static)
    for (std::int64_t s = 0; s < static_cast<std::int64_t>(size); ++s)
        order[s] = static_cast<std::uint32_t>(packed[s] & id_mask);
    return order;
}

}  // namespace pcl_rg
