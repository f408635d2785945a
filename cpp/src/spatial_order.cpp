// Radix sort and Morton order (see spatial_order.hpp).
#include "pcl_rg/spatial_order.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcl_rg {

void radix_sort_pairs(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& ids,
                      int key_bits) {
    constexpr int kDigitBits = 11;
    constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
    const std::size_t n = keys.size();
    if (n < 2 || key_bits <= 0) return;
    std::vector<std::uint64_t> keys_tmp(n);
    std::vector<std::uint32_t> ids_tmp(n);
    const int threads = std::max(1, std::min<int>(omp_get_max_threads(), static_cast<int>(n / 65536) + 1));
    std::vector<std::size_t> offsets(static_cast<std::size_t>(threads) * kBuckets);

    for (int shift = 0; shift < key_bits; shift += kDigitBits) {
        std::fill(offsets.begin(), offsets.end(), 0);
#pragma omp parallel num_threads(threads)
        {
            const int t = omp_get_thread_num();
            const std::size_t begin = n * t / threads, end = n * (t + 1) / threads;
            std::size_t* count = &offsets[t * kBuckets];
            for (std::size_t i = begin; i < end; ++i) ++count[(keys[i] >> shift) & (kBuckets - 1)];
#pragma omp barrier
#pragma omp single
            {
                // Bucket-major, thread-minor prefix sums: chunk t's items of a bucket
                // land after chunk t-1's, which is what makes the sort stable.
                std::size_t running = 0;
                for (std::size_t b = 0; b < kBuckets; ++b)
                    for (int u = 0; u < threads; ++u) {
                        const std::size_t c = offsets[u * kBuckets + b];
                        offsets[u * kBuckets + b] = running;
                        running += c;
                    }
            }
            for (std::size_t i = begin; i < end; ++i) {
                const std::size_t dst = count[(keys[i] >> shift) & (kBuckets - 1)]++;
                keys_tmp[dst] = keys[i];
                ids_tmp[dst] = ids[i];
            }
        }
        keys.swap(keys_tmp);
        ids.swap(ids_tmp);
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
    // One scale for all axes keeps the curve's cells cubic.
    const float extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30f});
    const double scale = static_cast<double>((1u << 21) - 1) / extent;
    std::vector<std::uint64_t> keys(size);
    std::vector<std::uint32_t> order(size);
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(size); ++i) {
        std::uint64_t code = 0;
        for (int a = 0; a < 3; ++a) {
            const auto q = static_cast<std::uint64_t>((xyz[3 * i + a] - lo[a]) * scale);
            code |= spread_bits(q) << a;
        }
        keys[i] = code;
        order[i] = static_cast<std::uint32_t>(i);
    }
    radix_sort_pairs(keys, order, 63);
    return order;
}

}  // namespace pcl_rg
