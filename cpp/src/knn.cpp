// k-nearest-neighbour search on nanoflann (see knn.hpp).
#include "pcl_rg/knn.hpp"

#include <limits>
#include <stdexcept>

namespace pcl_rg {

KnnIndex::KnnIndex(const float* xyz, std::size_t size) : adaptor_{xyz, size} {
    if (size > std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument("points: at most 2^32 - 1 points are supported, got " +
                                    std::to_string(size));
    // Leaf size 10 is nanoflann's default and measured fastest for k <= 50 here.
    tree_ = std::make_unique<Tree>(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
}

std::size_t KnnIndex::nearest(std::size_t query, std::size_t k, std::uint32_t* indices,
                              float* squared_distances) const {
    return tree_->knnSearch(adaptor_.xyz + 3 * query, k, indices, squared_distances);
}

}  // namespace pcl_rg
