#include "reefgen/procgen/age.hpp"

#include <algorithm>
#include <cmath>

#include "reefgen/terrain/erosion.hpp"

namespace reefgen::procgen {

IslandSpec aged(const IslandSpec& spec) {
  IslandSpec s = spec;
  s.age_myr = kNotSet, s.maturity = kNotSet;
  if (spec.age_myr == kNotSet && spec.maturity == kNotSet) return s;
  if (spec.age_myr != kNotSet) s.subsidence = subsidence_of_age(spec.age_myr);
  s.erosion = terrain::matured(spec.erosion, maturity_for(spec.age_myr, spec.maturity));
  return s;
}

}  // namespace reefgen::procgen
