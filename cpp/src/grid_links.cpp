// The components of the grid ground filter's link graph (see grid_links.hpp).
#include "pcl_rg/grid_links.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// The link test, as in the reference: same operations, same order (symmetric in s, q).
inline bool linked(const CellGrid& grid, std::size_t s, std::size_t q, double slope,
                   double tolerance) {
    const double dx = grid.p[s].x - grid.p[q].x, dy = grid.p[s].y - grid.p[q].y;
    const double d = std::sqrt(dx * dx + dy * dy);
    return std::abs(grid.p[s].z - grid.p[q].z) <= slope * d + tolerance;
}

// Positions [first, last) of cell c whose height lies within `reach` of z (all of them
// unless the cell's points rise, CellGrid::sorted_by_height): both ends by bisection on tests that
// are monotone along the cell, z - z_q > reach for those below and z_q - z > reach for those above,
// in the floating-point arithmetic of linked(), so that every q outside fails that test.
inline std::pair<std::size_t, std::size_t> within_reach(const CellGrid& grid, std::ptrdiff_t c,
                                                        double z, double reach) {
    const auto begin = grid.p.begin() + static_cast<std::ptrdiff_t>(grid.start[c]);
    const auto end = grid.p.begin() + static_cast<std::ptrdiff_t>(grid.start[c + 1]);
    if (begin == end || !grid.sorted_by_height(static_cast<std::size_t>(c)))
        return {grid.start[c], grid.start[c + 1]};
    // Mostly the whole cell is within reach: two tests instead of two bisections.
    const auto first =
        !(z - begin->z > reach)
            ? begin
            : std::partition_point(begin, end, [&](const Local& q) { return z - q.z > reach; });
    const auto last =
        !((end - 1)->z - z > reach)
            ? end
            : std::partition_point(first, end, [&](const Local& q) { return !(q.z - z > reach); });
    return {static_cast<std::size_t>(first - grid.p.begin()),
            static_cast<std::size_t>(last - grid.p.begin())};
}

// The links the sampling looks for per candidate. With one, the giant component of the
// ISPRS-like 10M-point scene stays small and the exact pass tests most points (grid_ground
// 1.6 -> 2.9 s); three gain nothing over two.
constexpr int kSampledLinks = 2;

// The points of a crowded cell that the sampling tries per candidate.
constexpr std::size_t kCrowdedTries = 32;

// The largest |z_s - z_q| with which s can link with a point q of crowded cell c (an
// upper bound): the link test's own threshold, slope * d + tolerance, at the farthest
// corner of the cell's XY box, in the same operations as linked(), so that rounding,
// monotone, keeps it an upper bound. Tighter than the 3 x 3 cells' bound: a pole of
// returns at one XY links only at its own height.
double crowded_reach(const CellGrid& grid, std::ptrdiff_t c, std::size_t s, double slope,
                     double tolerance) {
    const CellBox& box = grid.box_of_crowded(static_cast<std::size_t>(c));
    const double dx = std::max(std::abs(grid.p[s].x - box.x0), std::abs(grid.p[s].x - box.x1));
    const double dy = std::max(std::abs(grid.p[s].y - box.y0), std::abs(grid.p[s].y - box.y1));
    return slope * std::sqrt(dx * dx + dy * dy) + tolerance;
}

// Where each run of a crowded cell ends, for the exact pass: a run is a stretch of
// positions that are all non-candidates, or all candidates of one component by the
// roots' snapshot, and the pass steps over a run that cannot link in one step (a dense
// spot is mostly one component: one step, not a test per cell-mate).
class RunEnds {
   public:
    RunEnds(const CellGrid& grid, const std::vector<unsigned char>& candidate,
            const UnfilledVector<std::uint32_t>& root, bool parallel) {
        if (grid.crowded.empty()) return;
        end_ = UnfilledVector<std::uint32_t>(grid.p.size());  // read only where written
        const auto key = [&](std::size_t q) { return candidate[q] ? root[q] : kNone; };
        const auto count = static_cast<std::ptrdiff_t>(grid.crowded.size());
#pragma omp parallel for schedule(dynamic, 1) if (parallel)
        for (std::ptrdiff_t i = 0; i < count; ++i) {
            const std::size_t first = grid.start[grid.crowded[i]];
            const std::size_t last = grid.start[grid.crowded[i] + 1];
            end_[last - 1] = static_cast<std::uint32_t>(last);
            for (std::size_t q = last - 1; q-- > first;)
                end_[q] = key(q + 1) == key(q) ? end_[q + 1] : static_cast<std::uint32_t>(q + 1);
        }
    }

    /// The first position after q's run (q in a crowded cell).
    std::size_t operator[](std::size_t q) const { return end_[q]; }

   private:
    UnfilledVector<std::uint32_t> end_;
};

// The sampling's scan of a crowded cell (sorted by height), within `reach` of s's
// height. s's links lie near its height, and a scan from a random place would cross
// every height in between first: on a dense spot of distinct points, most of the cell
// per candidate. So the points nearest in height come first, alternately above and
// below, and only a few: the sampling only saves the exact pass work, and that pass
// finds every link.
template <class Link>
void sample_crowded(const CellGrid& grid, std::ptrdiff_t cell, std::size_t s, double reach,
                    Link link) {
    const auto [first, last] = within_reach(grid, cell, grid.p[s].z, reach);
    const double z = grid.p[s].z;
    const auto middle = static_cast<std::size_t>(
        std::partition_point(grid.p.begin() + static_cast<std::ptrdiff_t>(first),
                             grid.p.begin() + static_cast<std::ptrdiff_t>(last),
                             [z](const Local& q) { return q.z < z; }) -
        grid.p.begin());
    std::size_t above = middle, below = middle;  // next up: above; next down: below - 1
    for (std::size_t tries = 0; tries < kCrowdedTries && (above < last || below > first); ++tries) {
        const bool up = below == first || (above < last && tries % 2 == 0);
        if (link(up ? above++ : --below)) return;
    }
}

// Calls visit(s, around, k) for every candidate position s with the k occupied cells of
// its 3 x 3 neighbourhood, block by block in parallel: threads then mostly work on
// disjoint trees of the union-find instead of contending for the same roots.
template <class Visit>
void for_each_candidate(const CellGrid& grid, const std::vector<unsigned char>& candidate,
                        bool parallel, Visit visit) {
    const auto blocks = static_cast<std::ptrdiff_t>(grid.blocks);
    const Interruption interruption;
#pragma omp parallel for schedule(dynamic, 1) if (parallel) firstprivate(interruption)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        std::ptrdiff_t around[9];
        int k = 0;
        std::uint32_t current = kNone;
        for (std::size_t m = grid.block_start[b]; m < grid.block_start[b + 1]; ++m) {
            const std::uint32_t s = grid.block_member[m];
            if (!candidate[s]) continue;
            if (grid.cell[s] != current) {  // members come in cell order: few recomputes
                // Polled per cell, not per block: one block may hold the whole cloud.
                if (interruption.requested()) break;
                current = grid.cell[s];
                k = grid.neighbours(current, around);
            }
            visit(s, around, k);
        }
    }
    interruption.check();
}

// Who links with whom among the candidates (the reference's test, restricted as the
// options say), and how far in height a link can reach.
struct Links {
    const CellGrid& grid;
    const std::vector<unsigned char>& candidate;
    double slope, tolerance;
    bool across;
    // Points of a 3 x 3 block of cells lie less than 3 cells apart on each axis (up to
    // rounding of the cell index, relatively 2^-12 at 2^40 cells), so every computed
    // d is below 4 * (cell_x + cell_y) and a linked q has |z_s - z_q| <= slope * that
    // + tolerance (rounding is monotone): only heights within this reach are visited.
    double reach;

    Links(const CellGrid& grid, const GridGroundParams& params,
          const std::vector<unsigned char>& candidate)
        : grid(grid),
          candidate(candidate),
          slope(params.slope),
          tolerance(params.height_tolerance),
          across(params.grow_across_blocks),
          reach(params.slope * (4.0 * ((*params.cell_size)[0] + (*params.cell_size)[1])) +
                params.height_tolerance) {}

    // s (a candidate) and q are linked.
    bool joinable(std::size_t s, std::size_t q) const {
        return candidate[q] && (across || grid.block[q] == grid.block[s]) &&
               linked(grid, s, q, slope, tolerance);
    }
};

}  // namespace

void add_to_components(const CellGrid& grid, const GridGroundParams& params,
                       const std::vector<unsigned char>& candidate,
                       const std::vector<unsigned char>& before, ConcurrentDisjointSets& sets) {
    const Links links(grid, params, candidate);
    const auto count = static_cast<std::ptrdiff_t>(grid.p.size());
    const bool parallel = grid.p.size() >= kGridParallelMin;
    constexpr std::ptrdiff_t kChunk = 16384;
    const Interruption interruption;
#pragma omp parallel for schedule(dynamic, 1) if (parallel) firstprivate(interruption)
    for (std::ptrdiff_t chunk = 0; chunk < (count + kChunk - 1) / kChunk; ++chunk) {
        if (interruption.requested()) continue;
        std::ptrdiff_t around[9];
        int k = 0;
        std::uint32_t current = kNone;
        for (std::ptrdiff_t s = chunk * kChunk; s < std::min(count, (chunk + 1) * kChunk); ++s) {
            if (!candidate[s] || before[s]) continue;
            if (grid.copy_of_previous(static_cast<std::size_t>(s)) && candidate[s - 1] &&
                !before[s - 1]) {
                // A new candidate too, whose links are these.
                sets.unite(static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(s - 1));
                continue;
            }
            if (grid.cell[s] != current) {
                current = grid.cell[s];
                k = grid.neighbours(current, around);
            }
            for (int a = 0; a < k; ++a) {
                const auto [first, last] = within_reach(grid, around[a], grid.p[s].z, links.reach);
                for (std::size_t q = first; q < last; ++q)
                    if (q != static_cast<std::size_t>(s) && links.joinable(s, q))
                        sets.unite(static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(q));
            }
        }
    }
    interruption.check();
}

void label_components(const CellGrid& grid, const GridGroundParams& params,
                      const std::vector<unsigned char>& candidate, ConcurrentDisjointSets& sets,
                      UnfilledVector<std::uint32_t>& root) {
    const std::size_t n = grid.p.size();
    const bool across = params.grow_across_blocks;
    const bool parallel = n >= kGridParallelMin;
    const Links links(grid, params, candidate);
    const double reach = links.reach;
    const auto joinable = [&](std::size_t s, std::size_t q) { return links.joinable(s, q); };
    sets.reset(grid.p.size());
    for_each_candidate(
        grid, candidate, parallel, [&](std::size_t s, const std::ptrdiff_t* around, int k) {
            if (grid.copy_of_previous(s) && candidate[s - 1]) {  // its links are those
                sets.unite(static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(s - 1));
                return;
            }
            // From a pseudo-random one of the cells and place in it, round the lists:
            // the sampled links then run in every direction and join points of all
            // heights. (The cells in a fixed order made every point link into its
            // lower-left cell's lowest points: diagonal strips, a small giant.)
            int found = 0;
            // The first cell and the place in a cell from two multiplicative hashes of s,
            // scaled by a multiplication and a shift instead of a remainder (a division
            // each). Their high bits are taken: the low bits of s times an odd constant
            // repeat with s's, and the high bits of a smaller product barely move from one
            // s to the next (each cell's points then all tried the same neighbour first:
            // strips, a small giant, grid_ground 1.4 -> 2.2 s).
            const auto hash_cell =
                static_cast<std::uint32_t>((std::uint64_t{s} * 0x9E3779B97F4A7C15u) >> 32);
            const auto hash_place =
                static_cast<std::uint32_t>((std::uint64_t{s} * 0xC2B2AE3D27D4EB4Fu) >> 32);
            const auto scaled = [](std::uint32_t hash, std::size_t range) {
                return static_cast<std::size_t>((std::uint64_t{hash} * range) >> 32);
            };
            const auto link = [&](std::size_t q) {
                if (q == s || !joinable(s, q)) return false;
                sets.unite(static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(q));
                return ++found == kSampledLinks;
            };
            for (int j = 0, at = static_cast<int>(scaled(hash_cell, static_cast<std::size_t>(k)));
                 j < k && found < kSampledLinks; ++j, at = at + 1 == k ? 0 : at + 1) {
                const std::ptrdiff_t cell = around[at];
                const std::size_t first = grid.start[cell], size = grid.start[cell + 1] - first;
                if (grid.is_crowded(static_cast<std::size_t>(cell))) {
                    sample_crowded(grid, cell, s,
                                   crowded_reach(grid, cell, s, links.slope, links.tolerance),
                                   link);
                    continue;
                }
                const std::size_t offset = scaled(hash_place, size);
                for (std::size_t i = 0; i < size; ++i)
                    if (link(first + (offset + i < size ? offset + i : offset + i - size))) break;
            }
        });
    root.resize(n);  // written in full below
    const auto count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(guided) if (parallel)
    for (std::ptrdiff_t s = 0; s < count; ++s) root[s] = sets.find(static_cast<std::uint32_t>(s));
    const RunEnds run_end(grid, candidate, root, parallel);
    // Unites s with every point of cell c from position `from` on, within reach of its
    // height, that it links with and that is not already in its component (by the
    // snapshot): in a crowded cell, runs of such points and of points that are not
    // candidates are passed over in one step each.
    const auto join_cell = [&](std::size_t s, std::ptrdiff_t c, std::size_t from) {
        const bool crowded = grid.is_crowded(static_cast<std::size_t>(c));
        const auto [first, last] =
            within_reach(grid, c, grid.p[s].z,
                         crowded ? crowded_reach(grid, c, s, links.slope, links.tolerance) : reach);
        for (std::size_t q = std::max(first, from); q < last;) {
            if (root[q] == root[s] || !candidate[q]) {
                q = crowded ? run_end[q] : q + 1;
                continue;
            }
            if (joinable(s, q))
                sets.unite(static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(q));
            ++q;
        }
    };
    if (!across) {
        // Many mid-sized components, one or more per block: every unordered pair once,
        // from its smaller position.
        // A copy's pairs are its predecessor's, which also pairs with the copy.
        for_each_candidate(grid, candidate, parallel,
                           [&](std::size_t s, const std::ptrdiff_t* around, int k) {
                               if (grid.copy_of_previous(s) && candidate[s - 1]) return;
                               for (int a = 0; a < k; ++a) join_cell(s, around[a], s + 1);
                           });
        return;
    }
    std::vector<std::uint32_t> sample;
    const std::size_t step = std::max<std::size_t>(1, n / 4096);
    for (std::size_t s = 0; s < n; s += step)
        if (candidate[s]) sample.push_back(root[s]);
    std::sort(sample.begin(), sample.end());
    std::uint32_t giant = kNone;
    std::size_t best = 0;
    for (std::size_t i = 0, j; i < sample.size(); i = j) {
        for (j = i; j < sample.size() && sample[j] == sample[i]; ++j) {
        }
        if (j - i > best) best = j - i, giant = sample[i];
    }
    // A copy shares its predecessor's root (joined above): that one is tested.
    for_each_candidate(grid, candidate, parallel,
                       [&](std::size_t s, const std::ptrdiff_t* around, int k) {
                           if (root[s] == giant || (grid.copy_of_previous(s) && candidate[s - 1]))
                               return;
                           for (int a = 0; a < k; ++a) join_cell(s, around[a], 0);
                       });
}

}  // namespace pcl_rg
