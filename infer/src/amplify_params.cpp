#include "reefgen/infer/amplify_params.hpp"

#include <algorithm>
#include <cmath>

namespace reefgen::infer {

void to_json(nlohmann::json& j, const AmplifyParams& p) { j = params_json(p); }

AmplifyParams amplify_params_from_json(const nlohmann::json& j, const std::string& origin) {
  return params_from_json<AmplifyParams>(j, origin, "docs/EROSION.md", "erosion.");
}

AmplifyParams matured(const AmplifyParams& p, double maturity) {
  AmplifyParams a = p;
  a.erosion = terrain::matured(p.erosion, maturity);
  a.steps = std::max(a.steps, int(std::lround(a.steps * std::sqrt(maturity))));
  a.roughness *= std::min(1.0, maturity);
  a.lobe_m *= std::min(1.0, maturity);
  return a;
}

}  // namespace reefgen::infer
