// Parameter checks shared by every validate(): one rule, one wording. Each throws
// std::invalid_argument ("<name> must be <rule>, got <value>"), worded exactly as the
// Python dataclasses word it (pcl_rg/_params.py); tests/test_params.py feeds both
// layers the same invalid values and compares the messages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace pcl_rg::check {

/// Bounds of a number: inclusive (minimum, maximum) or exclusive (above, below).
struct Bounds {
    std::optional<double> minimum, above, maximum, below;

    /// ">= 1", "> 0", "in (0, 90]", ...: the rule as the messages state it.
    std::string rule() const;
    bool admits(double value) const;
};

/// Shortest text that reads back to the same double ("0.1", "1", "nan", "1e+300"),
/// as Python's repr() without a trailing ".0".
std::string format_value(double value);
std::string format_value(std::int64_t value);

/// A finite real within the bounds.
void real(const char* name, double value, const Bounds& bounds);
/// An integer within the bounds.
void integer(const char* name, std::int64_t value, const Bounds& bounds);
/// A relation between two parameters: `ok`, else "<name> must be <rule>, got <value>".
void relation(bool ok, const char* name, const std::string& rule, double value);

/// A neighbour count that the cloud can supply: "<name> must be < the number of points
/// (<n>), got <count>", the wording of the Python layer. With `cloud` > n, the n are what
/// is left of `cloud` points once the far ones are left out, and the message says so.
void fewer_than_points(const char* name, std::int64_t count, std::size_t n, std::size_t cloud = 0);

/// A per-point count whose total over n points stays within `total`: "<name> must be at
/// most <floor(total / n)> for <n> points (<why>), got <count>".
void per_point_at_most(const char* name, std::int64_t count, std::size_t n, double total,
                       const char* why);

/// A k x n table of uint32 neighbour indices within 8 GiB (per_point_at_most).
void neighbour_table_fits(const char* name, std::int64_t k, std::size_t n);

/// A cloud whose points int32 indices and labels can number: "points: at most 2^31 - 1
/// points are supported, got <n>".
void indexable_by_int32(std::size_t n);

/// Common bounds by name.
inline Bounds positive() { return Bounds{std::nullopt, 0.0, std::nullopt, std::nullopt}; }
inline Bounds non_negative() { return Bounds{0.0, std::nullopt, std::nullopt, std::nullopt}; }
inline Bounds at_least(double minimum) {
    return Bounds{minimum, std::nullopt, std::nullopt, std::nullopt};
}
inline Bounds any() { return Bounds{}; }

}  // namespace pcl_rg::check
