// k-nearest-neighbour search on nanoflann (see knn.hpp).
#include "pcl_rg/knn.hpp"

#include <limits>
#include <stdexcept>

namespace pcl_rg {

namespace {

// nanoflann's k-nearest list, except that a full list whose worst distance is 0 reports
// a worst distance of -infinity. nanoflann only offers a point to a full list when it is
// strictly closer than the worst, and enters a branch only when its box is no farther:
// with the worst at 0 no later leaf can offer anything, yet every branch at distance 0
// is still entered. Among many identical points that walk visits all of them for every
// query, O(n^2). Reporting -infinity prunes those branches and offers nothing new, while
// the leaf being scanned keeps the bound it started with, so the lists are the ones the
// full walk returns, ties included.
class NearestList : public nanoflann::KNNResultSet<float, std::uint32_t, std::size_t> {
   public:
    using KNNResultSet::KNNResultSet;
    float worstDist() const {
        const float worst = KNNResultSet::worstDist();
        return worst == 0.0f ? -std::numeric_limits<float>::infinity() : worst;
    }
};

}  // namespace

KnnIndex::KnnIndex(const float* xyz, std::size_t size) : adaptor_{xyz, size} {
    if (size > std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument("points: at most 2^32 - 1 points are supported, got " +
                                    std::to_string(size));
    // Leaf size 10 is nanoflann's default and measured fastest for k <= 50 here.
    tree_ = std::make_unique<Tree>(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
}

std::size_t KnnIndex::nearest(std::size_t query, std::size_t k, std::uint32_t* indices,
                              float* squared_distances) const {
    if (k == 0) return 0;  // nanoflann's list reads its last slot
    NearestList list(k);
    list.init(indices, squared_distances);
    tree_->findNeighbors(list, adaptor_.xyz + 3 * query, nanoflann::SearchParams());
    return list.size();
}

}  // namespace pcl_rg
