// Radix sorts and the Morton order (see spatial_order.hpp).
#include "pcl_rg/spatial_order.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

namespace {

// One stable counting-sort pass per digit over a fixed number of contiguous chunks;
// the bucket-major, chunk-minor prefix sums put chunk c's items of a bucket after chunk
// c-1's, which keeps the sort stable. The chunk count is fixed by the input size, not by
// the threads: OpenMP may grant a region fewer threads than asked (OMP_THREAD_LIMIT,
// OMP_DYNAMIC, a call from inside another parallel region), and worksharing loops over
// chunks cover every chunk whatever the team size. `Move` copies item i to slot dst.
// Once `interruption` is requested the remaining chunks are skipped: the caller must then
// throw (Interruption::check) rather than use the result.
template <class DigitOf, class Move>
void radix_pass(std::size_t n, DigitOf digit_of, Move move, std::size_t buckets,
                std::vector<std::size_t>& offsets, std::ptrdiff_t chunks,
                const Interruption& interruption) {
    std::fill(offsets.begin(), offsets.end(), 0);
    const auto chunk_begin = [&](std::ptrdiff_t c) {
        return n * static_cast<std::size_t>(c) / static_cast<std::size_t>(chunks);
    };
#pragma omp parallel if (chunks > 1) firstprivate(interruption)
    {
#pragma omp for schedule(static)
        for (std::ptrdiff_t c = 0; c < chunks; ++c) {
            if (interruption.requested()) continue;
            std::size_t* count = &offsets[static_cast<std::size_t>(c) * buckets];
            for (std::size_t i = chunk_begin(c), end = chunk_begin(c + 1); i < end; ++i)
                ++count[digit_of(i)];
        }
#pragma omp single
        {
            std::size_t running = 0;
            for (std::size_t b = 0; b < buckets; ++b)
                for (std::ptrdiff_t c = 0; c < chunks; ++c) {
                    std::size_t& slot = offsets[static_cast<std::size_t>(c) * buckets + b];
                    const std::size_t count = slot;
                    slot = running;
                    running += count;
                }
        }
#pragma omp for schedule(static)
        for (std::ptrdiff_t c = 0; c < chunks; ++c) {
            if (interruption.requested()) continue;
            std::size_t* next = &offsets[static_cast<std::size_t>(c) * buckets];
            for (std::size_t i = chunk_begin(c), end = chunk_begin(c + 1); i < end; ++i)
                move(i, next[digit_of(i)]++);
        }
    }
}

// Digits of at most 11 bits, as few passes as possible, equal widths.
int digit_width(int bits) {
    const int passes = (bits + 10) / 11;
    return (bits + passes - 1) / passes;
}

// Chunks of at least 64 Ki items (small inputs are not worth waking threads for), at most
// 64 of them so the per-chunk bucket counts stay small next to the data. The result of a
// stable sort does not depend on the chunking; the count only sets the parallelism.
std::ptrdiff_t chunk_count(std::size_t n) {
    return static_cast<std::ptrdiff_t>(std::min<std::size_t>(64, n / 65536 + 1));
}

}  // namespace

void radix_sort_pairs(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& ids,
                      int key_bits) {
    const std::size_t n = keys.size();
    if (n < 2 || key_bits <= 0) return;
    const int width = digit_width(key_bits);
    const std::size_t buckets = std::size_t{1} << width, mask = buckets - 1;
    const std::ptrdiff_t chunks = chunk_count(n);
    std::vector<std::size_t> offsets(static_cast<std::size_t>(chunks) * buckets);
    std::vector<std::uint64_t> keys_tmp(n);
    std::vector<std::uint32_t> ids_tmp(n);
    const Interruption interruption;
    for (int shift = 0; shift < key_bits; shift += width) {
        radix_pass(
            n, [&](std::size_t i) { return (keys[i] >> shift) & mask; },
            [&](std::size_t i, std::size_t dst) {
                keys_tmp[dst] = keys[i];
                ids_tmp[dst] = ids[i];
            },
            buckets, offsets, chunks, interruption);
        interruption.check();
        keys.swap(keys_tmp);
        ids.swap(ids_tmp);
    }
}

void radix_sort_bits(UnfilledVector<std::uint64_t>& values, int first_bit, int last_bit) {
    const std::size_t n = values.size();
    const int bits = last_bit - first_bit;
    if (n < 2 || bits <= 0) return;
    const int width = digit_width(bits);
    const std::size_t buckets = std::size_t{1} << width, mask = buckets - 1;
    const std::ptrdiff_t chunks = chunk_count(n);
    std::vector<std::size_t> offsets(static_cast<std::size_t>(chunks) * buckets);
    UnfilledVector<std::uint64_t> tmp(n);  // each pass writes every entry
    const Interruption interruption;
    for (int shift = first_bit; shift < last_bit; shift += width) {
        radix_pass(
            n, [&](std::size_t i) { return (values[i] >> shift) & mask; },
            [&](std::size_t i, std::size_t dst) { tmp[dst] = values[i]; }, buckets, offsets, chunks,
            interruption);
        interruption.check();
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
    UnfilledVector<std::uint64_t> packed(size);  // written in full below
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
