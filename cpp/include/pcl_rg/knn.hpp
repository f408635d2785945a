// k-nearest-neighbour search over float32 points, shared by the algorithms that
// need neighbourhoods (SOR, normals, region growing).
#pragma once

// Among the neighbours returned at equal distance, the lower index comes first.
// Which of several points tied at the k-th distance is returned is not the lowest
// index, though: once the list is full the walk (nanoflann's, knn.cpp) only takes
// strictly closer points, so the first one it meets stays. The traversal is deterministic
// for a given input, so lists are reproducible; references that compare with us
// on tied inputs must allow for the other choice at the k-th place.
#ifndef NANOFLANN_FIRST_MATCH
#define NANOFLANN_FIRST_MATCH
#endif
#include <cstddef>
#include <cstdint>
#include <memory>
#include <nanoflann.hpp>
#include <optional>

namespace pcl_rg {

namespace knn_tree {

// Points as nanoflann reads them.
struct Points {
    const float* xyz;
    std::size_t size;
    std::size_t kdtree_get_point_count() const { return size; }
    float kdtree_get_pt(std::size_t i, std::size_t axis) const { return xyz[3 * i + axis]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
        return false;
    }
};
using Distance = nanoflann::L2_Simple_Adaptor<float, Points>;
// Its split rule is knn.cpp's, not nanoflann's own (declared below).
using Tree = nanoflann::KDTreeSingleIndexAdaptor<Distance, Points, 3, std::uint32_t>;

}  // namespace knn_tree

}  // namespace pcl_rg

// The tree's own split rule (defined in knn.cpp): declared here so that every file that
// builds a knn_tree::Tree uses it, not nanoflann's (the one-definition rule).
template <>
void nanoflann::KDTreeBaseClass<
    pcl_rg::knn_tree::Tree, pcl_rg::knn_tree::Distance, pcl_rg::knn_tree::Points, 3,
    std::uint32_t>::middleSplit_(pcl_rg::knn_tree::Tree& obj, Offset ind, Size count, Offset& index,
                                 Dimension& cutfeat, DistanceType& cutval, const BoundingBox& bbox);

namespace pcl_rg {

/// k-d tree over row-major finite float32 x, y, z (the buffer must outlive the index).
/// Squared distances are summed in float over x, y, z in that order, as
/// pcl::KdTreeFLANN's L2_Simple does, so both return bit-identical distances. The
/// search is nanoflann's: exact but for its running float bound, which can, at the
/// last bit, pass over a point that ties the k-th distance to within rounding.
class KnnIndex {
   public:
    KnnIndex(const float* xyz, std::size_t size);

    /// The `k` nearest points to point `query` (itself included, at distance 0),
    /// ascending by squared distance; returns how many were found (min(k, size)).
    /// `leaf_budget`: the leaves nanoflann's walk may visit before the query walks
    /// again with the branches' boxes (knn.cpp); unset, 64 + k. The lists do not
    /// depend on it (tests set 0, every query by the boxes, and a huge one, none).
    /// `heap_from_k`: the least k whose list is kept in a heap rather than nanoflann's
    /// sorted list (knn.cpp); unset, knn.cpp's kHeapFrom. Nor do the lists depend on
    /// it (tests set 0, always the heap, and a huge one, never).
    std::size_t nearest(std::size_t query, std::size_t k, std::uint32_t* indices,
                        float* squared_distances,
                        std::optional<std::size_t> leaf_budget = std::nullopt,
                        std::optional<std::size_t> heap_from_k = std::nullopt) const;

    std::size_t size() const { return adaptor_.size; }

   private:
    template <class List>
    struct Search;  // the walk of nearest() over the tree (knn.cpp)
    // nearest() with a list of the k nearest so far of type List (knn.cpp).
    template <class List>
    std::size_t nearest_in(List& list, std::size_t query, std::size_t k, std::uint32_t* indices,
                           float* squared_distances, std::optional<std::size_t> leaf_budget) const;
    using Tree = knn_tree::Tree;
    knn_tree::Points adaptor_;
    std::unique_ptr<Tree> tree_;
};

}  // namespace pcl_rg
