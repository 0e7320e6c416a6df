#include "reefgen/procgen/spec.hpp"

#include <cmath>
#include <set>
#include <sstream>

#include "reefgen/io.hpp"
#include "reefgen/json_read.hpp"

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

std::string fmt(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

void check_range(const std::string& name, double v, double lo, double hi) {
  if (!std::isfinite(v) || v < lo || v > hi)
    throw Error(name + " = " + fmt(v) + " is out of range; expected [" + fmt(lo) + ", " + fmt(hi) + "]");
}

// Reads a JSON object field by field, remembering which keys were used, so
// that leftovers (typos) can be reported.
class Fields {
 public:
  Fields(const json& j, std::string path) : j_(j), path_(std::move(path)) {
    if (!j.is_object()) throw Error(path_ + " must be a JSON object");
  }
  template <class T>
  void get(const char* key, T& out) {
    used_.insert(key);
    auto it = j_.find(key);
    if (it == j_.end()) return;
    try {
      read_json_value(*it, out, path_ + "." + key);
    } catch (const json::exception&) {
      throw Error(path_ + "." + key + " has the wrong type (" + it->type_name() + ")");
    }
  }
  const json* find(const char* key) {
    used_.insert(key);
    auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }
  std::string at(const char* key) const { return path_ + "." + key; }
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!used_.count(it.key())) throw Error(path_ + ": unknown key \"" + it.key() + "\" (see docs/SPEC.md)");
  }

 private:
  const json& j_;
  std::string path_;
  std::set<std::string> used_;
};

Vec2 vec2_from_json(const json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 2 || !j[0].is_number() || !j[1].is_number())
    throw Error(path + " must be a point [x, y]");
  return {j[0].get<double>(), j[1].get<double>()};
}

}  // namespace

void validate(const IslandSpec& s) {
  for (int i = 0; i < kNumOutlines; ++i) {
    const std::string name = "outlines[" + std::to_string(i) + "]";
    if (s.outlines[i].empty()) throw Error(name + " is empty; give one radius (circle) or several");
    if (s.outlines[i].size() > 4096) throw Error(name + " has more than 4096 radii");
    for (double r : s.outlines[i]) check_range(name + " radius", r, 1e-3, 3.0);
  }
  check_range("min_gap", s.min_gap, 0.001, 0.2);
  for (const auto* c : {&s.profile, &s.resistance}) {
    const std::string name = c == &s.profile ? "profile" : "resistance";
    if (c->size() < 2 || c->size() > 4096) throw Error(name + " needs 2..4096 samples, got " + std::to_string(c->size()));
    for (double v : *c) check_range(name + " sample", v, 0.0, 1.0);
  }
  if (s.wind.size() > 64) throw Error("wind has " + std::to_string(s.wind.size()) + " strokes; at most 64");
  for (size_t i = 0; i < s.wind.size(); ++i) {
    const std::string name = "wind[" + std::to_string(i) + "]";
    const auto& w = s.wind[i];
    if (w.points.size() < 2 || w.points.size() > 1024) throw Error(name + ".points needs 2..1024 points");
    for (const auto& p : w.points) {
      check_range(name + ".points x", p.x, -4, 4);
      check_range(name + ".points y", p.y, -4, 4);
    }
    check_range(name + ".strength", w.strength, 0, 2);
    check_range(name + ".width", w.width, 0.005, 2);
  }
  if (s.wind_substeps < 1 || s.wind_substeps > 100) throw Error("wind_substeps = " + std::to_string(s.wind_substeps) + " is out of range; expected [1, 100]");
  check_range("subsidence", s.subsidence, 0, 1);
  check_params(s.heights, "", "docs/SPEC.md", "heights.");
  const auto& c = s.coral;
  check_params(c, "", "docs/SPEC.md", "coral.");
  check_range("coral.crest_begin", c.crest_begin, c.back_end, 1);
  check_range("coral.crest_end", c.crest_end, c.crest_begin, 1);
  check_range("smax_k", s.smax_k, 0.01, 100);
  check_params(s.noise, "", "docs/SPEC.md", "noise.");
  check_range("world_size_m", s.world_size_m, 10, 1e6);
}

void to_json(json& j, const IslandSpec& s) {
  json outlines = json::array();
  for (const auto& o : s.outlines) outlines.push_back(o.size() == 1 ? json(o[0]) : json(o));
  json wind = json::array();
  for (const auto& w : s.wind) {
    json pts = json::array();
    for (const auto& p : w.points) pts.push_back({p.x, p.y});
    wind.push_back({{"points", pts}, {"strength", w.strength}, {"width", w.width}});
  }
  j = json{{"description", s.description},
           {"outlines", outlines},
           {"min_gap", s.min_gap},
           {"profile", s.profile},
           {"resistance", s.resistance},
           {"wind", wind},
           {"wind_substeps", s.wind_substeps},
           {"subsidence", s.subsidence},
           {"heights", params_json(s.heights)},
           {"coral", params_json(s.coral)},
           {"smax_k", s.smax_k},
           {"noise", params_json(s.noise)},
           {"world_size_m", s.world_size_m}};
  to_json(j["erosion"], s.erosion);
}

void from_json(const json& j, IslandSpec& s) {
  Fields f(j, "spec");
  f.get("description", s.description);
  if (const json* o = f.find("outlines")) {
    if (!o->is_array() || o->size() != kNumOutlines)
      throw Error("spec.outlines must be an array of 5 outlines (island, beach, lagoon, reef, abyss)");
    for (int i = 0; i < kNumOutlines; ++i) {
      const json& e = (*o)[i];
      const std::string path = "spec.outlines[" + std::to_string(i) + "]";
      if (e.is_number()) s.outlines[i] = {e.get<double>()};
      else if (e.is_array() && std::all_of(e.begin(), e.end(), [](const json& v) { return v.is_number(); }))
        s.outlines[i] = e.get<std::vector<double>>();
      else throw Error(path + " must be a radius or an array of radii");
    }
  }
  f.get("min_gap", s.min_gap);
  f.get("profile", s.profile);
  f.get("resistance", s.resistance);
  if (const json* w = f.find("wind")) {
    if (!w->is_array()) throw Error("spec.wind must be an array of strokes");
    s.wind.clear();
    for (size_t i = 0; i < w->size(); ++i) {
      const std::string path = "spec.wind[" + std::to_string(i) + "]";
      Fields fw((*w)[i], path);
      WindStroke st;
      if (const json* pts = fw.find("points")) {
        if (!pts->is_array()) throw Error(path + ".points must be an array of [x, y]");
        for (size_t k = 0; k < pts->size(); ++k)
          st.points.push_back(vec2_from_json((*pts)[k], path + ".points[" + std::to_string(k) + "]"));
      }
      fw.get("strength", st.strength);
      fw.get("width", st.width);
      fw.finish();
      s.wind.push_back(std::move(st));
    }
  }
  // Read as a number first: 1e30 is refused against [1, 100], not int's range.
  if (const json* w = f.find("wind_substeps")) {
    double d = 0;
    read_json_value(*w, d, "spec.wind_substeps");
    check_range("spec.wind_substeps", d, 1, 100);
    if (d != std::floor(d)) throw Error("spec.wind_substeps = " + fmt(d) + " must be a whole number in [1, 100]");
    s.wind_substeps = int(d);
  }
  f.get("subsidence", s.subsidence);
  if (const json* h = f.find("heights")) s.heights = params_from_json<HeightMapping>(*h, "", "docs/SPEC.md", "heights.");
  if (const json* c = f.find("coral")) s.coral = params_from_json<CoralParams>(*c, "", "docs/SPEC.md", "coral.");
  f.get("smax_k", s.smax_k);
  if (const json* n = f.find("noise")) s.noise = params_from_json<DetailNoise>(*n, "", "docs/SPEC.md", "noise.");
  if (const json* e = f.find("erosion")) s.erosion = erosion_params_from_json(*e, "spec");
  f.get("world_size_m", s.world_size_m);
  f.finish();
}

IslandSpec spec_from_json(const json& j, const std::string& origin) {
  IslandSpec s;
  try {
    from_json(j, s);
    validate(s);
  } catch (const Error& e) {
    throw Error(origin + ": " + e.what());
  }
  return s;
}

}  // namespace reefgen::procgen
