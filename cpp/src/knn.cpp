// k-nearest-neighbour search on nanoflann's k-d tree (see knn.hpp).
#include "pcl_rg/knn.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

// The walk below reads nanoflann's tree as 1.4 lays it out (Node, vAcc, root_bbox, and
// divlow/divhigh as the children's own extents along the split axis).
static_assert(NANOFLANN_VERSION >= 0x140 && NANOFLANN_VERSION < 0x150,
              "knn.cpp walks nanoflann 1.4's tree: check its layout and searchLevel first");

// nanoflann 1.4 chooses a node's split axis among those where the node's *cell* (its
// parent's cell cut at the parent's split) is widest, taking the one its points spread
// most along. When every point of the node has the same value there (points on a line
// or plane parallel to the axes, inside a cell that is wider across them), the split
// value is that one value, half the points go each way by index, and both children's
// cells keep the same width on that axis: every later split down to the leaves repeats
// it, the children's extents coincide, and a query walks every point of its line. Three
// vertical lines of 100k points took SOR 5.4 s against 0.36 s with 1e-9 m of jitter.
//
// This replaces nanoflann's split for our tree only: the same choice wherever the chosen
// axis separates the points, so trees, and which of several points tied at the k-th
// distance a list keeps, are unchanged on such clouds; and the axis of the points' widest
// spread where it would not. A node of copies (no spread on any axis) is still cut by
// index, as nanoflann does: the walk stops at once among copies (see walk()).
template <>
void nanoflann::KDTreeBaseClass<pcl_rg::knn_tree::Tree, pcl_rg::knn_tree::Distance,
                                pcl_rg::knn_tree::Points, 3,
                                std::uint32_t>::middleSplit_(pcl_rg::knn_tree::Tree& obj,
                                                             Offset ind, Size count, Offset& index,
                                                             Dimension& cutfeat,
                                                             DistanceType& cutval,
                                                             const BoundingBox& bbox) {
    constexpr Dimension kDims = 3;
    float widest_cell = bbox[0].high - bbox[0].low;
    for (Dimension axis = 1; axis < kDims; ++axis)
        widest_cell = std::max(widest_cell, bbox[axis].high - bbox[axis].low);
    const float near_widest = (1 - static_cast<float>(0.00001)) * widest_cell;

    std::array<float, kDims> low{}, high{};
    for (Dimension axis = 0; axis < kDims; ++axis)
        computeMinMax(obj, ind, count, axis, low[axis], high[axis]);
    float spread = -1.0f;
    cutfeat = 0;
    for (Dimension axis = 0; axis < kDims; ++axis) {
        if (bbox[axis].high - bbox[axis].low > near_widest && high[axis] - low[axis] > spread) {
            cutfeat = axis;
            spread = high[axis] - low[axis];
        }
    }
    if (spread == 0.0f) {  // the cell's widest axes do not separate these points
        for (Dimension axis = 0; axis < kDims; ++axis) {
            if (high[axis] - low[axis] > spread) {
                cutfeat = axis;
                spread = high[axis] - low[axis];
            }
        }
    }
    const float middle = (bbox[cutfeat].low + bbox[cutfeat].high) / 2;
    cutval = std::clamp(middle, low[cutfeat], high[cutfeat]);

    Offset below = 0, up_to = 0;  // points < cutval come first, then those == cutval
    planeSplit(obj, ind, count, cutfeat, cutval, below, up_to);
    index = below > count / 2 ? below : up_to < count / 2 ? up_to : count / 2;
}

namespace pcl_rg {

namespace {

// nanoflann's KNNResultSet keeps the k nearest found so far by (distance, index)
// (NANOFLANN_FIRST_MATCH, knn.hpp): full once it holds k, and then a point below the
// greatest (distance, index) replaces it. It inserts by shifting, O(k) a point taken;
// for k near the number of points a query takes most of them, and SOR with mean_k
// 5000 on 20k points took 47 s (PCL's own 11 s). HeapList keeps the same list as a
// max-heap on (distance, index), O(log k) a point, sorted once at the end: the same
// greatest drops, so the same list, ties included.
//
// A pair is one 64-bit key, the distance's bits above the index: squared distances are
// sums of squares, never negative or NaN, and such floats order as their bits do, so
// one integer comparison orders the pairs, and the final sort can be a radix sort.
// Measured on SOR over 200k uniform points (medians of 3 fresh processes, against
// SortedList below k = 192 and a heap of (float, index) structs from 192): the same at
// k = 64, 11 % faster at 96, 47 % at 128, 43 % at 192 and 47 % at 256; on 20k points
// in a plane, mean_k 1000 0.96 -> 0.46 s and mean_k 5000 5.17 -> 2.00 s.
constexpr std::size_t kHeapFrom = 96;

using SortedList = nanoflann::KNNResultSet<float, std::uint32_t, std::size_t>;

class HeapList {
   public:
    explicit HeapList(std::size_t capacity) : capacity_(capacity) {}

    void init(std::uint32_t* indices, float* squared_distances) {
        indices_ = indices;
        squared_distances_ = squared_distances;
        heap_.clear();
        heap_.reserve(capacity_);
        worst_ = std::numeric_limits<float>::max();
    }
    std::size_t size() const { return heap_.size(); }
    bool full() const { return heap_.size() == capacity_; }
    float worstDist() const { return worst_; }  // float max until full, as SortedList
    void addPoint(float squared_distance, std::uint32_t index) {
        const std::uint64_t key = key_of(squared_distance, index);
        if (!full()) {  // a heap only once full: until then nothing drops
            heap_.push_back(key);
            if (!full()) return;
            std::make_heap(heap_.begin(), heap_.end());
        } else if (key < heap_.front()) {
            // A leaf tests its points against the worst as it was when the leaf began
            // (walk()), so one past the current greatest can come: SortedList shifts
            // nothing for it, and it is not taken here either.
            replace_greatest(key);
        } else {
            return;
        }
        worst_ = distance_of(heap_.front());
    }
    // The list, ascending, into the arrays given to init() (SortedList writes there as
    // it goes).
    void finish() {
        sort_keys();
        for (std::size_t i = 0; i < heap_.size(); ++i) {
            indices_[i] = static_cast<std::uint32_t>(heap_[i]);
            squared_distances_[i] = distance_of(heap_[i]);
        }
    }

   private:
    static std::uint64_t key_of(float squared_distance, std::uint32_t index) {
        std::uint32_t bits;
        std::memcpy(&bits, &squared_distance, sizeof bits);
        return (std::uint64_t{bits} << 32) | index;
    }
    static float distance_of(std::uint64_t key) {
        const auto bits = static_cast<std::uint32_t>(key >> 32);
        float squared_distance;
        std::memcpy(&squared_distance, &bits, sizeof bits);
        return squared_distance;
    }

    // The root's key replaced by a smaller one, sifted down: one pass of log k steps
    // where std::pop_heap and std::push_heap take two.
    void replace_greatest(std::uint64_t key) {
        const std::size_t n = heap_.size();
        std::size_t hole = 0;
        for (std::size_t child = 1; child < n; child = 2 * hole + 1) {
            if (child + 1 < n && heap_[child] < heap_[child + 1]) ++child;
            if (!(key < heap_[child])) break;
            heap_[hole] = heap_[child];
            hole = child;
        }
        heap_[hole] = key;
    }

    // Ascending keys. With thousands of keys std::sort took a quarter of a list's time;
    // a least-significant-digit radix sort takes one counting pass and one scatter per
    // byte, and skips a byte every key shares (the index's top bytes on smaller clouds).
    void sort_keys() {
        const std::size_t n = heap_.size();
        if (n < kRadixSortFrom) {
            std::sort(heap_.begin(), heap_.end());
            return;
        }
        scratch_.resize(n);
        std::uint64_t* from = heap_.data();
        std::uint64_t* to = scratch_.data();
        for (int shift = 0; shift < 64; shift += 8) {
            std::array<std::size_t, 256> place{};  // counts, then each digit's first slot
            for (std::size_t i = 0; i < n; ++i) ++place[(from[i] >> shift) & 0xff];
            if (place[(from[0] >> shift) & 0xff] == n) continue;
            std::size_t sum = 0;
            for (std::size_t& slot : place) sum += std::exchange(slot, sum);
            for (std::size_t i = 0; i < n; ++i) to[place[(from[i] >> shift) & 0xff]++] = from[i];
            std::swap(from, to);
        }
        if (from != heap_.data()) std::copy(from, from + n, heap_.data());
    }

    static constexpr std::size_t kRadixSortFrom = 128;  // below it std::sort is as fast

    std::size_t capacity_;
    std::vector<std::uint64_t> heap_;
    std::vector<std::uint64_t> scratch_;  // the radix sort's other buffer
    std::uint32_t* indices_ = nullptr;
    float* squared_distances_ = nullptr;
    float worst_ = std::numeric_limits<float>::max();
};

void finish(SortedList&) {}
void finish(HeapList& list) { list.finish(); }

}  // namespace

// nanoflann's own walk (KDTreeSingleIndexAdaptor::findNeighbors with its searchLevel):
// the same order of branches, the same float bounds and the same leaf test, so the
// same lists, ties included. nanoflann enters a branch when its bound is no farther
// than the list's worst distance, yet a leaf takes only points strictly nearer than
// the worst. So once the list is full, a branch that lies no nearer than the worst can
// add nothing, and nanoflann walks it all the same. Among many copies of a point that
// all lie at the k-th distance (two stacks of repeated returns a centimetre apart, or
// a point beside such a stack), every query walked every copy: O(n^2).
//
// So a query walks as nanoflann does while it has visited at most kLeafBudget + k
// leaves (an ordinary query visits a few to a few dozen leaves of 10 points), and
// otherwise walks again from the root with one more cut: once the list is full, a branch whose box
// lies no nearer than the worst distance is skipped. The second walk gives the list the first would
// have given, and the first walk's partial list is dropped, so the result never depends on which
// walk finished. (Tracking the boxes costs about 10 % of SOR's time on ordinary clouds, hence not
// always.)
//
// The cut needs a bound that is never above the distance a leaf computes for a point
// of the branch. That distance is float arithmetic: (q - p) per axis, squared, summed
// over x, y, z in that order (no FMA contraction: CMakeLists.txt). The bound is that
// same arithmetic on the point of the branch's box nearest to q. Per axis |q - c| <=
// |q - p| exactly, and rounding, squaring and adding non-negative numbers never
// reverse an order, so the bound is at most the distance of every point in the box.
// The box starts as nanoflann's bounding box of all points and is cut at each split
// by the extent of the child's own points along the split axis (nanoflann's divlow,
// divhigh).
template <class List>
struct KnnIndex::Search {
    using Node = Tree::Node;
    static constexpr int kDims = 3;
    static constexpr std::size_t kLeafBudget = 64;

    const Tree& tree;
    const float* xyz;
    const float* query;
    List& list;
    std::size_t leaves_left = 0;             // of the first walk's budget
    std::array<float, kDims> low{}, high{};  // the box of the branch being walked (second walk)
    std::array<float, kDims> cut{};          // nanoflann's per-axis part of its bound

    float squared_distance(const float* point) const {
        float sum = 0.0f;
        for (int axis = 0; axis < kDims; ++axis) {
            const float diff = query[axis] - point[axis];
            sum += diff * diff;
        }
        return sum;
    }

    // True when no point of the current box can enter the full list.
    bool beyond_worst() const {
        if (!list.full()) return false;
        std::array<float, kDims> nearest{};
        for (int axis = 0; axis < kDims; ++axis)
            nearest[axis] = std::clamp(query[axis], low[axis], high[axis]);
        return squared_distance(nearest.data()) >= list.worstDist();
    }

    // nanoflann's searchLevel; with kCut, the boxes and their cut too. False: the first
    // walk ran out of leaves.
    template <bool kCut>
    bool walk(const Node* node, float bound) {
        if (node->child1 == nullptr && node->child2 == nullptr) {
            if (!kCut && leaves_left-- == 0) return false;
            const float worst = list.worstDist();  // fixed for the leaf, as in nanoflann
            for (auto i = node->node_type.lr.left; i < node->node_type.lr.right; ++i) {
                const std::uint32_t id = tree.vAcc[i];
                const float distance = squared_distance(xyz + 3 * static_cast<std::size_t>(id));
                if (distance < worst) list.addPoint(distance, id);
            }
            return true;
        }
        const auto axis = node->node_type.sub.divfeat;
        const float value = query[axis];
        const float below = node->node_type.sub.divlow;   // largest value in child1
        const float above = node->node_type.sub.divhigh;  // smallest value in child2
        const bool child1_first = (value - below) + (value - above) < 0;
        const Node* first = child1_first ? node->child1 : node->child2;
        const Node* second = child1_first ? node->child2 : node->child1;
        const float edge = child1_first ? above : below;
        const float cut_distance = (value - edge) * (value - edge);
        const float saved_low = low[axis], saved_high = high[axis];

        if (kCut) {
            if (child1_first)
                high[axis] = std::min(saved_high, below);
            else
                low[axis] = std::max(saved_low, above);
        }
        if (!walk<kCut>(first, bound)) return false;

        const float saved_cut = cut[axis];
        const float second_bound = bound + cut_distance - saved_cut;
        cut[axis] = cut_distance;
        if (kCut) {
            low[axis] = child1_first ? std::max(saved_low, above) : saved_low;
            high[axis] = child1_first ? saved_high : std::min(saved_high, below);
        }
        // A full list at distance 0 can take nothing more (a leaf takes only nearer
        // points): each of many copies of one point stops at once, in either walk.
        const float worst = list.worstDist();
        if (second_bound <= worst && worst > 0.0f && !(kCut && beyond_worst()) &&
            !walk<kCut>(second, second_bound))
            return false;
        cut[axis] = saved_cut;
        if (kCut) {
            low[axis] = saved_low;
            high[axis] = saved_high;
        }
        return true;
    }
};

KnnIndex::KnnIndex(const float* xyz, std::size_t size) : adaptor_{xyz, size} {
    if (size > std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument("points: at most 2^32 - 1 points are supported, got " +
                                    std::to_string(size));
    // Leaf size 10 is nanoflann's default and measured fastest for k <= 50 here.
    tree_ = std::make_unique<Tree>(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
}

std::size_t KnnIndex::nearest(std::size_t query, std::size_t k, std::uint32_t* indices,
                              float* squared_distances, std::optional<std::size_t> leaf_budget,
                              std::optional<std::size_t> heap_from_k) const {
    if (k == 0 || adaptor_.size == 0 || tree_->root_node == nullptr) return 0;
    // (k = 0 would read SortedList's last slot.) One walk per kind of list, so that
    // the usual short lists pay nothing for the choice.
    if (k >= heap_from_k.value_or(kHeapFrom)) {
        HeapList list(k);
        return nearest_in(list, query, k, indices, squared_distances, leaf_budget);
    }
    SortedList list(k);
    return nearest_in(list, query, k, indices, squared_distances, leaf_budget);
}

template <class List>
std::size_t KnnIndex::nearest_in(List& list, std::size_t query, std::size_t k,
                                 std::uint32_t* indices, float* squared_distances,
                                 std::optional<std::size_t> leaf_budget) const {
    using Walk = Search<List>;
    list.init(indices, squared_distances);
    Walk search{*tree_, adaptor_.xyz, adaptor_.xyz + 3 * query, list};
    // The query is one of the points, inside the box of them all: nanoflann's initial
    // bound and its per-axis parts are 0.
    search.leaves_left = leaf_budget.value_or(Walk::kLeafBudget + k);
    if (!search.template walk<false>(tree_->root_node, 0.0f)) {
        list.init(indices, squared_distances);
        search.cut = {};
        for (int axis = 0; axis < Walk::kDims; ++axis) {
            search.low[axis] = tree_->root_bbox[axis].low;
            search.high[axis] = tree_->root_bbox[axis].high;
        }
        search.template walk<true>(tree_->root_node, 0.0f);
    }
    finish(list);
    return list.size();
}

}  // namespace pcl_rg
