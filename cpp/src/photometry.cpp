#include "moonbot/photometry.h"

#include <sstream>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

std::string number(double value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

const ParamRange& photometry_range(const std::string& field) {
    for (const ParamRange& range : kPhotometryRanges)
        if (field == range.field) return range;
    throw std::logic_error("no photometry range for " + field);
}

/// Throws unless `value` lies in `field`'s range, its bounds multiplied by `scale` (the unit the
/// value is stored in); the message gives the value in the range's unit (value / scale).
void check(const std::string& field, double value, double scale = 1.0) {
    const ParamRange& r = photometry_range(field);
    const ParamRange stored{r.field, r.lo * scale, r.hi * scale, r.lo_open, r.hi_open};
    if (stored.contains(value)) return;
    throw std::invalid_argument(field + ": must be in " + (r.lo_open ? "(" : "[") + number(r.lo) + ", " + number(r.hi) +
                                (r.hi_open ? ")" : "]") + ", got " + number(value / scale));
}

}  // namespace

void Photometry::validate() const {
    check("surge_amplitude", surge_amplitude);
    check("surge_width", surge_width);
    check("w", hapke.w);
    check("b", hapke.b);
    check("c", hapke.c);
    check("roughness_deg", hapke.roughness_rad, kRadPerDeg);
    check("filling_factor", hapke.filling_factor);
    check("cboe_amplitude", hapke.cboe_amplitude);
    check("cboe_width", hapke.cboe_width);
}

}  // namespace moonbot
