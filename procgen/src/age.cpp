#include "reefgen/procgen/age.hpp"

#include <algorithm>
#include <cmath>

namespace reefgen::procgen {

double subsidence_of_age(double age_myr) { return std::min(1.0, std::sqrt(std::max(0.0, age_myr) / kAtollAgeMyr)); }

double maturity_of_age(double age_myr) {
  return std::clamp(age_myr / kUnitMaturityAgeMyr, kMinMaturity, kMaxMaturity);
}

IslandSpec aged(const IslandSpec& spec) {
  IslandSpec s = spec;
  s.age_myr = kNotSet, s.maturity = kNotSet;
  if (spec.age_myr == kNotSet && spec.maturity == kNotSet) return s;
  if (spec.age_myr != kNotSet) s.subsidence = subsidence_of_age(spec.age_myr);
  const double m = spec.maturity != kNotSet ? spec.maturity : maturity_of_age(spec.age_myr);
  auto& e = s.erosion;
  e.duration_yr *= m;
  // The implicit steps stay stable at any length; more of them for a longer
  // time keep the valleys' walls from being cut in a few coarse strokes.
  e.steps = std::max(e.steps, int(std::lround(e.steps * std::sqrt(m))));
  e.channel_head_m2 = std::max(e.channel_head_m2, kAgedChannelHeadM2);
  return s;
}

}  // namespace reefgen::procgen
