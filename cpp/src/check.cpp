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
    char buffer[64];
    // Shortest round-trip form, the digits Python's repr() prints.
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
    return std::string(buffer, end);
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

void fewer_than_points(const char* name, std::int64_t count, std::size_t n) {
    if (count < 0 || static_cast<std::uint64_t>(count) >= n)
        throw std::invalid_argument(std::string(name) + " must be < the number of points (" +
                                    std::to_string(n) + "), got " + std::to_string(count));
}

void indexable_by_int32(std::size_t n) {
    if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::invalid_argument("points: at most 2^31 - 1 points are supported, got " +
                                    std::to_string(n));
}

}  // namespace pcl_rg::check
