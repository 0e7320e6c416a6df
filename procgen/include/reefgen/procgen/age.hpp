#pragma once
// One age for an island (docs/SPEC.md "Age"): how long ago its shield was
// built sets both how far it has sunk (the subsidence λ: fringing reef →
// barrier reef → atoll, Darwin's sequence) and how far rivers have
// dissected it (the erosion maturity: a young shield's shallow radial
// gullies → an old island's deep valleys between high ridges). Either can
// be set on its own: `subsidence` (with age_myr unset) and `maturity`.
#include "reefgen/age.hpp"
#include "reefgen/procgen/spec.hpp"

namespace reefgen::procgen {

// The spec with age_myr and maturity applied and both cleared: subsidence
// from the age (when set), the erosion matured (terrain::matured). Both
// unset: the spec unchanged (the same bytes as before ages existed).
IslandSpec aged(const IslandSpec& spec);

}  // namespace reefgen::procgen
