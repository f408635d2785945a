// Parameter checks shared by every validate() (see check.hpp).
#include "pcl_rg/check.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace pcl_rg::check {

std::string format_value(double value) {
    if (std::isnan(value)) return "nan";
    if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
    // The shortest digits that read back to the value (as Python's repr() picks them), in
    // repr()'s layout: scientific below 1e-4 and from 1e16 on, else positional (without
    // repr()'s ".0"). to_chars's own choice is the shorter text, "1e+05" for 100000.
    char buffer[64];
    const auto end =
        std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::scientific).ptr;
    const std::string scientific(buffer, end);  // "-1.25e+05"
    const std::size_t e = scientific.find('e');
    const int exponent = std::stoi(scientific.substr(e + 1));
    if (exponent < -4 || exponent >= 16) return scientific;
    const bool negative = scientific[0] == '-';
    std::string digits;
    for (std::size_t k = negative ? 1 : 0; k < e; ++k)
        if (scientific[k] != '.') digits += scientific[k];
    const int before_point = exponent + 1;  // digits before the decimal point
    const auto count = static_cast<int>(digits.size());
    std::string text;
    if (before_point <= 0)
        text = "0." + std::string(static_cast<std::size_t>(-before_point), '0') + digits;
    else if (before_point >= count)
        text = digits + std::string(static_cast<std::size_t>(before_point - count), '0');
    else
        text = digits.substr(0, static_cast<std::size_t>(before_point)) + "." +
               digits.substr(static_cast<std::size_t>(before_point));
    return negative ? "-" + text : text;
}

std::string format_value(std::int64_t value) { return std::to_string(value); }

std::string Bounds::rule() const {
    const bool has_low = above || minimum, has_high = below || maximum;
    const double low = above ? *above : minimum.value_or(0.0);
    const double high = below ? *below : maximum.value_or(0.0);
    if (has_low && has_high)
        return std::string("in ") + (above ? "(" : "[") + format_value(low) + ", " +
               format_value(high) + (below ? ")" : "]");
    if (has_low) return std::string(above ? "> " : ">= ") + format_value(low);
    if (has_high) return std::string(below ? "< " : "<= ") + format_value(high);
    return "";
}

bool Bounds::admits(double value) const {
    return (!minimum || value >= *minimum) && (!above || value > *above) &&
           (!maximum || value <= *maximum) && (!below || value < *below);
}

void real(const char* name, double value, const Bounds& bounds) {
    if (!std::isfinite(value))
        throw std::invalid_argument(std::string(name) + " must be finite, got " +
                                    format_value(value));
    if (!bounds.admits(value))
        throw std::invalid_argument(std::string(name) + " must be " + bounds.rule() + ", got " +
                                    format_value(value));
}

void integer(const char* name, std::int64_t value, const Bounds& bounds) {
    if (!bounds.admits(static_cast<double>(value)))
        throw std::invalid_argument(std::string(name) + " must be " + bounds.rule() + ", got " +
                                    format_value(value));
}

void relation(bool ok, const char* name, const std::string& rule, double value) {
    if (!ok)
        throw std::invalid_argument(std::string(name) + " must be " + rule + ", got " +
                                    format_value(value));
}

void fewer_than_points(const char* name, std::int64_t count, std::size_t n, std::size_t cloud) {
    if (count >= 0 && static_cast<std::uint64_t>(count) < n) return;
    const std::string far = cloud > n ? " within float32's reach, of " + std::to_string(cloud) +
                                            ": " + std::to_string(cloud - n) + " far, left out"
                                      : "";
    throw std::invalid_argument(std::string(name) + " must be < the number of points (" +
                                std::to_string(n) + far + "), got " + std::to_string(count));
}

// The neighbour table of region growing and convex segmentation holds k uint32 per
// point for the whole run. 8 GiB is a third of the 24 GiB machines this is built for,
// and 2000 neighbours per point on 1M points; k = N - 1 on 100k points asked for 40 GB
// and failed with a bare MemoryError.
constexpr double kMaxNeighbourTableBytes = 0x1p33;

void per_point_at_most(const char* name, std::int64_t count, std::size_t n, double total,
                       const char* why) {
    const double largest = std::floor(total / static_cast<double>(n));
    if (static_cast<double>(count) > largest)
        throw std::invalid_argument(std::string(name) + " must be at most " +
                                    format_value(largest) + " for " + std::to_string(n) +
                                    " points (" + why + "), got " + std::to_string(count));
}

void neighbour_table_fits(const char* name, std::int64_t k, std::size_t n) {
    per_point_at_most(name, k, n, kMaxNeighbourTableBytes / 4.0,
                      "a table of k neighbour indices per point, 4 bytes each, is kept "
                      "within 8 GiB");
}

void indexable_by_int32(std::size_t n) {
    if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::invalid_argument("points: at most 2^31 - 1 points are supported, got " +
                                    std::to_string(n));
}

}  // namespace pcl_rg::check
