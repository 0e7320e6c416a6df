#include "reefgen/procgen/spec.hpp"

#include "reefgen/procgen/age.hpp"

#include <cmath>
#include <algorithm>

#include "reefgen/files.hpp"
#include "reefgen/text.hpp"

namespace reefgen::procgen {

using nlohmann::json;

std::vector<double> default_profile() {
  return {.963, .898, .843, .776, .689, .648, .597, .561, .539, .509, .499, .484, .481, .478, .476,
          .474, .460, .456, .441, .432, .426, .316, .248, .015, .015, .015, .010, .001, 0,    0};
}

std::vector<double> default_resistance() {
  return {.743, .715, .676, .627, .582, .524, .426, .270, .147, .085, .037, .031, .028, .028, .028,
          .040, .061, .083, .106, .156, .222, .312, .484, .644, .747, .862, .049, .034, .021, .003};
}

namespace {

void check_range(const std::string& name, double v, double lo, double hi) {
  if (!std::isfinite(v) || v < lo || v > hi)
    throw Error(name + " = " + short_num(v) + " is out of range; expected [" + short_num(lo) + ", " + short_num(hi) + "]");
}

}  // namespace

nlohmann::json points_to_json(const std::vector<Vec2>& points) {
  json a = json::array();
  for (const auto& p : points) a.push_back({p.x, p.y});
  return a;
}

void points_from_json(const json& j, std::vector<Vec2>& points, const std::string& where) {
  if (!j.is_array()) throw Error(where + " must be an array of [x, y]");
  points.clear();
  for (size_t k = 0; k < j.size(); ++k) {
    const json& e = j[k];
    if (!e.is_array() || e.size() != 2 || !e[0].is_number() || !e[1].is_number())
      throw Error(where + "[" + std::to_string(k) + "] must be a point [x, y]");
    points.push_back({e[0].get<double>(), e[1].get<double>()});
  }
}

void check_points(const std::vector<Vec2>& points, const std::string& where) {
  if (points.size() < 2 || points.size() > 1024) throw Error(where + " needs 2..1024 points, got " + std::to_string(points.size()));
  for (size_t k = 0; k < points.size(); ++k) {
    check_range(where + "[" + std::to_string(k) + "] x", points[k].x, -4, 4);
    check_range(where + "[" + std::to_string(k) + "] y", points[k].y, -4, 4);
  }
}

nlohmann::json outlines_to_json(const Outlines& o) {
  json a = json::array();
  for (const auto& r : o) a.push_back(r.size() == 1 ? json(r[0]) : json(r));
  return a;
}

void outlines_from_json(const json& j, Outlines& o, const std::string& where) {
  if (!j.is_array() || j.size() != kNumOutlines)
    throw Error(where + " must be an array of 5 outlines (island, beach, lagoon, reef, abyss)");
  for (int i = 0; i < kNumOutlines; ++i) {
    const json& e = j[size_t(i)];
    if (e.is_number()) o[size_t(i)] = {e.get<double>()};
    else if (e.is_array() && std::all_of(e.begin(), e.end(), [](const json& v) { return v.is_number(); }))
      o[size_t(i)] = e.get<std::vector<double>>();
    else throw Error(where + "[" + std::to_string(i) + "] must be a radius or an array of radii");
  }
}

void check_outlines(const Outlines& o, const std::string& where) {
  for (int i = 0; i < kNumOutlines; ++i) {
    const std::string name = where + "[" + std::to_string(i) + "]";
    const auto& r = o[size_t(i)];
    if (r.empty()) throw Error(name + " is empty; give one radius (circle) or several");
    if (r.size() > 4096) throw Error(name + " has more than 4096 radii");
    for (double v : r) check_range(name + " radius", v, 1e-3, 3.0);
  }
}

void validate(const IslandSpec& s) {
  check_params(s, "", "docs/SPEC.md");
  // Rules between fields, which the walk's per-field ranges cannot say.
  const auto& c = s.coral;
  check_range("coral.flat_begin", c.flat_begin, c.back_end, 1);
  size_t pass_points = 0;
  for (const auto& p : s.reef.passes) pass_points += p.points.size();
  if (pass_points > size_t(kMaxPassPoints))
    throw Error("reef.passes have " + std::to_string(pass_points) + " points in all; at most " +
                std::to_string(kMaxPassPoints) + " (a pass needs a handful: the channel is a smooth curve)");
  check_range("coral.crest_begin", c.crest_begin, c.flat_begin, 1);
  check_range("coral.crest_end", c.crest_end, c.crest_begin, 1);
  if (s.age_myr != kNotSet) check_range("age_myr", s.age_myr, 0, kMaxAgeMyr);
  if (s.maturity != kNotSet) check_range("maturity", s.maturity, kMinMaturity, kMaxMaturity);
}

void to_json(json& j, const IslandSpec& s) { j = params_json(s); }

void from_json(const json& j, IslandSpec& s) { s = params_from_json<IslandSpec>(j, "", "docs/SPEC.md"); }

IslandSpec spec_from_json(const json& j, const std::string& origin) {
  IslandSpec s;
  try {
    from_json(j, s);
    validate(s);
    // An age (or a maturity) is applied once, here: what every reader of a
    // spec file gets is the island it describes (subsidence and erosion set).
    s = aged(s);
  } catch (const Error& e) {
    throw Error(origin + ": " + e.what());
  }
  return s;
}

}  // namespace reefgen::procgen
